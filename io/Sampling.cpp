#include "io/Sampling.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/Stability.h"  // Interrupted
#include "sparse/LeafGeometry.h"

namespace mpm {

void SamplePart::checkStop() const {
    if (stop && stop->load(std::memory_order_relaxed) != 0) throw Interrupted();
}

namespace {
/// A lattice of the given spacing over the shape's bounds, each point jittered, those inside kept; of a
/// part, only its range of them. The jitter is drawn in lattice order, so a part takes two passes (count,
/// then keep its range) and holds only its points: the parts are the whole sampling cut.
template <class Shape>
std::vector<Vec3d> jitteredGrid(const Shape& shape, double spacing, double jitterFraction, unsigned seed, SamplePart part = {}) {
    Vec3d lo, hi;
    shape.bounds(lo, hi);
    const Vec3i n = ((hi - lo) / spacing).array().ceil().cast<int>();
    auto eachInside = [&](auto&& f) {
        std::mt19937 rng(seed);
        std::uniform_real_distribution<double> jitter(-jitterFraction * spacing, jitterFraction * spacing);
        for (int i = 0; i < n[0]; ++i, part.checkStop())
            for (int j = 0; j < n[1]; ++j)
                for (int k = 0; k < n[2]; ++k) {
                    const Vec3d x =
                        lo + (Vec3d(i, j, k) + Vec3d::Constant(0.5)) * spacing + Vec3d(jitter(rng), jitter(rng), jitter(rng));
                    if (shape.contains(x)) f(x);
                }
    };
    std::vector<Vec3d> out;
    if (part.parts <= 1) {
        eachInside([&](const Vec3d& x) { out.push_back(x); });
        return out;
    }
    std::size_t total = 0, k = 0;
    eachInside([&](const Vec3d&) { ++total; });
    // Plain variables, not a structured binding: clang 14 cannot capture one in a lambda.
    const std::pair<std::size_t, std::size_t> range = part.range(total);
    const std::size_t begin = range.first, end = range.second;
    eachInside([&](const Vec3d& x) {
        if (k >= begin && k < end) out.push_back(x);
        ++k;
    });
    return out;
}

/// Bridson's growth (2007) run tile by tile so that any region can be sampled alone and give the points
/// the whole shape would have there (Wei 2008, "Parallel Poisson disk sampling", phase groups of tiles).
/// The shape's bounds are covered by tiles of kTileCells^3 background cells (cell r / sqrt 3, one sample at
/// most). Tiles are filled in 8 phases by the parity of their coordinates: neighbouring tiles differ in phase,
/// and two tiles of one phase are a tile apart (> r), so no two of them compete for a point. A tile grows
/// from the samples of its earlier-phase neighbours, then seeds the cells 2 r clear of every point (a point
/// drawn in the cell, then its centre) and grows again, all with its own generator seeded by the set's seed
/// and the tile's coordinate. A tile's points thus depend only on tiles within 7 of it (phase 7 reads phase
/// 6, which reads phase 5, ...), and sampling a range of tiles fills that range grown by 7 - phase tiles for
/// each phase.
template <class Shape>
class PoissonTilesIn {
public:
    PoissonTilesIn(const Shape& shape, double r, unsigned seed, const SamplePart& stop = {})
        : shape_(shape), r_(r), cell_(r / std::sqrt(3.0)), seed_(seed), stop_(stop) {
        shape.bounds(lo_, hi_);
        const Vec3d span = ((hi_ - lo_) / (cell_ * kTileCells)).array().ceil().max(1.0);
        if (span.maxCoeff() > double(kMaxTiles))
            throw std::length_error("Poisson-disk sampling: the shape is " + std::to_string(span.maxCoeff()) +
                                    " tiles of 4.6 minimum distances long, more than " + std::to_string(kMaxTiles));
        tiles_ = span.cast<int>();
        reachR_ = offsetsWithin(r_), reachSeed_ = offsetsWithin(kSeedSpacing * r_),
        reachPiece_ = offsetsWithin(kPieceSeedSpacing * r_);
    }
    Vec3i tileCounts() const { return tiles_; }

    /// The points of `wanted` (tile coordinates in [0, tileCounts())), tile after tile in that order.
    std::vector<Vec3d> sample(const std::vector<Vec3i>& wanted) {
        // Which tiles each phase must fill: those of that phase within 7 - phase tiles of a wanted one.
        std::vector<std::vector<Vec3i>> fill(kPhases);
        const long long all = (long long)tiles_[0] * tiles_[1] * tiles_[2];
        if ((long long)wanted.size() == all) {
            for (const Vec3i& t : wanted) fill[std::size_t(phaseOf(t))].push_back(t);
        } else {
            std::unordered_map<uint64_t, int> reach;  // tile -> how far it lies from the wanted ones (<= 7)
            std::vector<Vec3i> front = wanted;
            for (const Vec3i& t : wanted) reach.emplace(key(t), 0);
            for (int d = 1; d < kPhases && !front.empty(); ++d) {
                std::vector<Vec3i> next;
                for (const Vec3i& t : front)
                    for (int i = -1; i <= 1; ++i)
                        for (int j = -1; j <= 1; ++j)
                            for (int k = -1; k <= 1; ++k) {
                                const Vec3i n = t + Vec3i(i, j, k);
                                if ((n.array() < 0).any() || (n.array() >= tiles_.array()).any()) continue;
                                if (reach.emplace(key(n), d).second) next.push_back(n);
                            }
                front = std::move(next);
            }
            for (const auto& [k, d] : reach) {
                const Vec3i t = tileOfKey(k);
                if (d <= kPhases - 1 - phaseOf(t)) fill[std::size_t(phaseOf(t))].push_back(t);
            }
            // The map's order is the library's: fill each phase in a fixed order (the result does not depend
            // on it, the tiles of a phase being independent, but the work then always runs the same way).
            for (auto& f : fill) std::sort(f.begin(), f.end(), [](const Vec3i& a, const Vec3i& b) { return mortonLess(a, b); });
        }
        // The tiles of a phase never read one another: they fill in parallel. Each reads its neighbours of
        // earlier phases, filled before, and writes its own entry, made before the phase starts.
        for (int p = 0; p < kPhases; ++p) {
            const std::vector<Vec3i>& phase = fill[std::size_t(p)];
            for (const Vec3i& t : phase) done_[key(t)];
            tbb::parallel_for(tbb::blocked_range<std::size_t>(0, phase.size()), [&](const tbb::blocked_range<std::size_t>& r) {
                for (std::size_t i = r.begin(); i < r.end(); ++i) stop_.checkStop(), fillTile(phase[i]);
            });
        }
        // The halo's tiles go first, and each wanted tile's points are released once copied: the peak stays
        // near one copy of the points.
        std::unordered_map<uint64_t, Tile> kept;
        std::size_t count = 0;
        for (const Vec3i& t : wanted)
            if (auto node = done_.extract(key(t)); !node.empty()) count += node.mapped().pts.size(), kept.insert(std::move(node));
        done_.clear();
        std::vector<Vec3d> out;
        out.reserve(count);
        for (const Vec3i& t : wanted) {
            const auto it = kept.find(key(t));
            if (it == kept.end()) continue;
            out.insert(out.end(), it->second.pts.begin(), it->second.pts.end());
            kept.erase(it);
        }
        return out;
    }

private:
    static constexpr int kTileCells = 8;              ///< background cells along a tile's edge (a tile is 4.6 r wide)
    static constexpr int kMaxTiles = (1 << 20) - 2;   ///< along an axis: what a key's 21 bits hold
    static constexpr int kTileShift = 3;              ///< log2(kTileCells)
    static constexpr int kPhases = 8;                 ///< tile parities in 3D
    static constexpr double kSeedSpacing = 2.0;       ///< in r: a tile seeds a new growth this clear of points
    static constexpr double kPieceSeedSpacing = 1.5;  ///< in r: a file's thin pieces are seeded this clear of points

    /// Cell offsets whose cells may hold a point nearer than `spacing` to a point of the centre cell, by their
    /// least distance (cell * |max(|o| - 1, 0)|).
    std::vector<Vec3i> offsetsWithin(double spacing) const {
        const int w = int(std::ceil(spacing / cell_));
        std::vector<std::pair<double, Vec3i>> all;
        for (int i = -w; i <= w; ++i)
            for (int j = -w; j <= w; ++j)
                for (int k = -w; k <= w; ++k) {
                    const Vec3i o(i, j, k);
                    const double least = cell_ * (o.cwiseAbs() - Vec3i::Ones()).cwiseMax(0).cast<double>().norm();
                    if (least < spacing) all.emplace_back(least, o);
                }
        std::stable_sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
        std::vector<Vec3i> out;
        for (const auto& e : all) out.push_back(e.second);
        return out;
    }
    struct Tile {
        std::vector<Vec3d> pts;
        std::array<int16_t, kTileCells * kTileCells * kTileCells> cell;  ///< index in pts of the cell's point, or -1
    };

    static int phaseOf(const Vec3i& t) { return (t[0] & 1) | (t[1] & 1) << 1 | (t[2] & 1) << 2; }
    /// Tiles lie in [-1, 2^20 - 2] along each axis (a tile is at least r wide: 2^20 of them is far beyond memory).
    static uint64_t key(const Vec3i& t) { return uint64_t(t[0] + 1) << 42 | uint64_t(t[1] + 1) << 21 | uint64_t(t[2] + 1); }
    static Vec3i tileOfKey(uint64_t k) {
        constexpr uint64_t m = (uint64_t(1) << 21) - 1;
        return Vec3i(int(k >> 42 & m) - 1, int(k >> 21 & m) - 1, int(k & m) - 1);
    }
    static int localOf(const Vec3i& c) {
        constexpr int m = kTileCells - 1;
        return ((c[0] & m) * kTileCells + (c[1] & m)) * kTileCells + (c[2] & m);
    }
    Vec3i cellOf(const Vec3d& x) const { return ((x - lo_) / cell_).array().floor().cast<int>(); }

    void fillTile(const Vec3i& t) {
        Tile& me = done_.find(key(t))->second;
        me.cell.fill(-1);
        // The 27 tiles around (earlier phases filled, later ones absent): a candidate's 5^3 cells lie in them.
        const Tile* around[27];
        for (int i = 0; i < 27; ++i) {
            const auto it = done_.find(key(t + Vec3i(i / 9 - 1, i / 3 % 3 - 1, i % 3 - 1)));
            around[i] = it == done_.end() ? nullptr : &it->second;
        }
        // No point nearer than `spacing` (r, or more for a seed; within the 27 tiles): the cells that can hold
        // one, nearest first, so that a crowded place is told apart after a few lookups.
        auto clearWithin = [&](const Vec3d& x, const std::vector<Vec3i>& reach, double spacing) {
            const Vec3i c = cellOf(x);
            for (const Vec3i& o : reach) {
                const Vec3i n = c + o;
                const Vec3i d = Vec3i(n[0] >> kTileShift, n[1] >> kTileShift, n[2] >> kTileShift) - t + Vec3i::Ones();
                const Tile* tile = around[(d[0] * 3 + d[1]) * 3 + d[2]];
                if (!tile) continue;
                const int s = tile->cell[std::size_t(localOf(n))];
                if (s >= 0 && (tile->pts[std::size_t(s)] - x).squaredNorm() < spacing * spacing) return false;
            }
            return true;
        };
        auto clearOf = [&](const Vec3d& x) { return clearWithin(x, reachR_, r_); };
        // A point belongs to this tile when its cell does (the test the lookups above make, rounding included).
        // A file's shape is read through a sampler of this task's own.
        const auto shape = [&] {
            if constexpr (requires { shape_.withOwnSampler(); })
                return shape_.withOwnSampler();
            else
                return shape_;
        }();
        // A tile the shape's field shows to be wholly outside gets no point: skip its lookups (the tiles of a thin
        // or hollow file's box away from its surface).
        const Vec3d boxLo = lo_ + t.cast<double>() * (cell_ * kTileCells), boxHi = boxLo + Vec3d::Constant(cell_ * kTileCells);
        if constexpr (requires { shape.outside(boxLo, boxHi); })
            if (shape.outside(boxLo, boxHi)) return;
        auto mine = [&](const Vec3d& x) {
            if ((x.array() < lo_.array()).any() || (x.array() >= hi_.array()).any()) return false;
            const Vec3i c = cellOf(x);
            return Vec3i(c[0] >> kTileShift, c[1] >> kTileShift, c[2] >> kTileShift) == t && shape.contains(x);
        };
        std::mt19937 rng(tileSeed(t));
        std::uniform_real_distribution<double> u01(0.0, 1.0);
        std::vector<Vec3d> active;
        auto accept = [&](const Vec3d& x) {
            me.cell[std::size_t(localOf(cellOf(x)))] = int16_t(me.pts.size());
            me.pts.push_back(x);
            active.push_back(x);
        };
        auto grow = [&] {
            while (!active.empty()) {
                const std::size_t pick = std::size_t(u01(rng) * double(active.size())) % active.size();
                const Vec3d centre = active[pick];
                bool found = false;
                for (int a = 0; a < kPoissonAttempts && !found; ++a) {
                    // Uniform in the spherical shell [r, 2r).
                    Vec3d dir(u01(rng) * 2 - 1, u01(rng) * 2 - 1, u01(rng) * 2 - 1);
                    const double len = dir.norm();
                    if (len < 1e-9 || len > 1.0) continue;
                    const Vec3d x = centre + dir / len * (r_ * std::cbrt(1.0 + 7.0 * u01(rng)));
                    if (mine(x) && clearOf(x)) {
                        accept(x);
                        found = true;
                    }
                }
                if (!found) {
                    active[pick] = active.back();
                    active.pop_back();
                }
            }
        };
        // Grow from the neighbours' points that can reach into this tile (within 2 r of it).
        for (const Tile* tile : around)
            if (tile && tile != &me)
                for (const Vec3d& x : tile->pts) {
                    const Vec3d gap = (boxLo - x).cwiseMax(x - boxHi).cwiseMax(0.0);
                    if (gap.squaredNorm() < 4.0 * r_ * r_) active.push_back(x);
                }
        grow();
        // Then every cell 2 r from any point seeds (a random point in it, else its centre) and grows: the first
        // points of a tile no neighbour reached, and pieces of the shape the growth did not reach. (Seeding
        // wherever r allows would fill the growth's gaps too, denser along the tiles' faces.)
        auto seedFreeCells = [&](const std::vector<Vec3i>& reach, double spacing, bool random) {
            for (int i = 0; i < kTileCells; ++i)
                for (int j = 0; j < kTileCells; ++j)
                    for (int k = 0; k < kTileCells; ++k) {
                        const Vec3i c = t * kTileCells + Vec3i(i, j, k);
                        if (me.cell[std::size_t(localOf(c))] >= 0) continue;
                        const Vec3d corner = lo_ + c.cast<double>() * cell_;
                        const Vec3d centre = corner + Vec3d::Constant(0.5 * cell_);
                        const Vec3d tries[2] = {random ? Vec3d(corner + cell_ * Vec3d(u01(rng), u01(rng), u01(rng))) : centre,
                                                centre};
                        for (int q = random ? 0 : 1; q < 2; ++q)
                            if (const Vec3d& x = tries[q]; cellOf(x) == c && mine(x) && clearWithin(x, reach, spacing)) {
                                accept(x);
                                grow();
                                break;
                            }
                    }
        };
        seedFreeCells(reachSeed_, kSeedSpacing * r_, true);
        // A file's shape may hold thin pieces near others: cell centres 1.5 r clear of all points seed too
        // (r would fill the growth's gaps as well, 7% denser than the other shapes).
        if constexpr (requires { Shape::kMayBeDisconnected; }) seedFreeCells(reachPiece_, kPieceSeedSpacing * r_, false);
    }

    /// The tile's own generator: the set's seed and the tile's coordinate mixed (splitmix64's finaliser).
    unsigned tileSeed(const Vec3i& t) const {
        uint64_t z = key(t) * 0x9e3779b97f4a7c15ull + seed_;
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
        return unsigned(z ^ (z >> 31));
    }

    const Shape& shape_;
    double r_, cell_;
    unsigned seed_;
    SamplePart stop_;  ///< its stop request alone
    Vec3d lo_, hi_;
    Vec3i tiles_;
    std::vector<Vec3i> reachR_, reachSeed_, reachPiece_;  ///< offsetsWithin r, and the seeds' spacings
    std::unordered_map<uint64_t, Tile> done_;
};

/// Every tile of the shape's bounds, in Morton order: the order of a set's samples.
inline std::vector<Vec3i> tilesInOrder(const Vec3i& n) {
    std::vector<Vec3i> out;
    out.reserve(std::size_t(n[0]) * std::size_t(n[1]) * std::size_t(n[2]));
    for (int i = 0; i < n[0]; ++i)
        for (int j = 0; j < n[1]; ++j)
            for (int k = 0; k < n[2]; ++k) out.emplace_back(i, j, k);
    std::sort(out.begin(), out.end(), [](const Vec3i& a, const Vec3i& b) { return mortonLess(a, b); });
    return out;
}

/// Tiles [part / parts, (part + 1) / parts) of the shape's tiles in Morton order: the part's share.
template <class Shape>
std::vector<Vec3d> poissonDiskIn(const Shape& shape, double r, unsigned seed, SamplePart part) {
    PoissonTilesIn<Shape> tiles(shape, r, seed, part);
    std::vector<Vec3i> order = tilesInOrder(tiles.tileCounts());
    if (part.parts > 1) {
        const auto [begin, end] = part.range(order.size());
        order = std::vector<Vec3i>(order.begin() + std::ptrdiff_t(begin), order.begin() + std::ptrdiff_t(end));
    }
    return tiles.sample(order);
}

/// Samples [part / parts, (part + 1) / parts) of a sampling made whole.
std::vector<Vec3d> shareOf(std::vector<Vec3d> all, SamplePart part) {
    if (part.parts <= 1) return all;
    const auto [begin, end] = part.range(all.size());
    return std::vector<Vec3d>(all.begin() + std::ptrdiff_t(begin), all.begin() + std::ptrdiff_t(end));
}

/// An exact count is met by sampling again, finer, while the shape holds fewer points (a sphere holds a few
/// lattice points less than its volume implies). Far short of it (under kFarShort of the count: a file's field
/// that holds much less than the volume it reports) the spacing shrinks at once by the cube root of the share
/// found; and it may not shrink below 1 / kFinestSpacing of the first one (8 times the density the volume
/// implies): a shape that would need more, or holds no point at all, is an error, not an endless refinement.
constexpr double kFarShort = 0.5;
constexpr double kFinestSpacing = 2.0;

template <class Shape>
std::vector<Vec3d> sampleIn(const Shape& shape, double dx, double particlesPerCell, long long count, Sampling method,
                            unsigned seed, SamplePart part) {
    const double perVolume = count > 0 ? double(count) / shape.volume() : particlesPerCell / (dx * dx * dx);
    const bool poisson = method == Sampling::Poisson;
    const double jitter = method == Sampling::Grid ? kGridJitter : 0.0;
    // The lattice's spacing, or the Poisson-disk radius.
    double spacing = poisson ? std::cbrt(1.0 / (kPoissonPacking * perVolume)) : std::cbrt(1.0 / perVolume);
    auto sample = [&](double at, SamplePart p) {
        return poisson ? poissonDiskIn(shape, at, seed, p) : jitteredGrid(shape, at, jitter, seed, p);
    };
    // A set given by its density samples its part alone; an exact count picks from the whole.
    if (count <= 0) return sample(spacing, part);
    const SamplePart whole{0, 1, part.stop};
    std::vector<Vec3d> pts = sample(spacing, whole);
    const double finest = spacing / kFinestSpacing, step = poisson ? 0.95 : 0.97;
    while ((long long)pts.size() < count) {
        const double found = double(pts.size()) / double(count);
        spacing *= found >= kFarShort ? step : std::cbrt(found);
        if (spacing < finest) {
            std::ostringstream why;
            why << "it holds " << pts.size() << " of the " << count << " particles `count` asks for, and would need "
                << "sampling at more than " << kFinestSpacing * kFinestSpacing * kFinestSpacing
                << " times the density its volume (" << shape.volume()
                << " m^3) implies; a file's field may be too coarse for its thin parts (a smaller voxel_size), or ask "
                   "for fewer particles";
            throw std::domain_error(why.str());
        }
        pts = sample(spacing, whole);
    }
    if ((long long)pts.size() > count) {
        std::mt19937 rng(seed ^ 0x9e3779b9u);
        std::shuffle(pts.begin(), pts.end(), rng);
        pts.resize(std::size_t(count));
    }
    return shareOf(std::move(pts), part);
}

}  // namespace

std::vector<Vec3d> poissonDisk(const SetRegion& shape, double r, unsigned seed, SamplePart part) {
    return std::visit([&](const auto& s) { return poissonDiskIn(s, r, seed, part); }, shape);
}

std::vector<Vec3d> sampleShape(const SetRegion& shape, double dx, double particlesPerCell, long long count, Sampling method,
                               unsigned seed, SamplePart part) {
    return std::visit([&](const auto& s) { return sampleIn(s, dx, particlesPerCell, count, method, seed, part); }, shape);
}

double shapeVolume(const SetRegion& shape) {
    return std::visit([](const auto& s) { return s.volume(); }, shape);
}

}  // namespace mpm
