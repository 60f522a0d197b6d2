#include "io/Sampling.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <unordered_map>

namespace mpm {

namespace {
template <class Shape>
std::vector<Vec3d> jitteredGrid(const Shape& shape, double spacing, double jitterFraction, unsigned seed) {
    Vec3d lo, hi;
    shape.bounds(lo, hi);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> jitter(-jitterFraction * spacing, jitterFraction * spacing);
    std::vector<Vec3d> out;
    const Vec3i n = ((hi - lo) / spacing).array().ceil().cast<int>();
    for (int i = 0; i < n[0]; ++i)
        for (int j = 0; j < n[1]; ++j)
            for (int k = 0; k < n[2]; ++k) {
                const Vec3d x =
                    lo + (Vec3d(i, j, k) + Vec3d::Constant(0.5)) * spacing + Vec3d(jitter(rng), jitter(rng), jitter(rng));
                if (shape.contains(x)) out.push_back(x);
            }
    return out;
}

/// Bridson's growth from the active samples until none can place a new one.
template <class Shape, class CellOf, class ClearOf, class Accept>
void grow(const Shape& shape, const std::vector<Vec3d>& samples, std::vector<int32_t>& active, const Vec3d& lo, const Vec3d& hi, double r,
          std::mt19937& rng, CellOf&& cellOf, ClearOf&& clearOf, Accept&& accept) {
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    while (!active.empty()) {
        const std::size_t pick = std::size_t(u01(rng) * active.size()) % active.size();
        const Vec3d centre = samples[active[pick]];
        bool found = false;
        for (int a = 0; a < kPoissonAttempts && !found; ++a) {
            // Uniform in the spherical shell [r, 2r).
            Vec3d dir(u01(rng) * 2 - 1, u01(rng) * 2 - 1, u01(rng) * 2 - 1);
            const double len = dir.norm();
            if (len < 1e-9 || len > 1.0) continue;
            const double rad = r * std::cbrt(1.0 + 7.0 * u01(rng));
            const Vec3d x = centre + dir / len * rad;
            if ((x.array() < lo.array()).any() || (x.array() >= hi.array()).any() || !shape.contains(x)) continue;
            if (clearOf(x)) {
                accept(x);
                found = true;
            }
        }
        if (!found) {
            active[pick] = active.back();
            active.pop_back();
        }
    }
}

template <class Shape>
std::vector<Vec3d> poissonDiskIn(const Shape& shape, double r, unsigned seed) {
    Vec3d lo, hi;
    shape.bounds(lo, hi);
    // Background grid of cell r / sqrt(3): each cell holds at most one sample.
    const double cell = r / std::sqrt(3.0);
    const Vec3i dims = ((hi - lo) / cell).array().ceil().cast<int>().max(1);
    const long long cells = (long long)dims[0] * dims[1] * dims[2];
    std::vector<int32_t> grid(std::size_t(cells), -1);
    auto cellOf = [&](const Vec3d& x) {
        return ((x - lo) / cell).array().floor().cast<int>().min(dims.array() - 1).max(0).matrix().eval();
    };
    auto flat = [&](const Vec3i& c) { return (std::size_t(c[0]) * dims[1] + c[1]) * dims[2] + c[2]; };
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    std::vector<Vec3d> samples, inside;
    std::vector<int32_t> active;
    auto accept = [&](const Vec3d& x) {
        grid[flat(cellOf(x))] = int32_t(samples.size());
        active.push_back(int32_t(samples.size()));
        samples.push_back(x);
    };
    // Seeds: the first point inside the shape from a few random tries.
    for (int tries = 0; tries < 1000 && samples.empty(); ++tries) {
        const Vec3d x = lo + Vec3d(u01(rng), u01(rng), u01(rng)).cwiseProduct(hi - lo);
        if (shape.contains(x)) accept(x);
    }
    auto clearOf = [&](const Vec3d& x) {
        const Vec3i c = cellOf(x);
        for (int i = std::max(0, c[0] - 2); i <= std::min(dims[0] - 1, c[0] + 2); ++i)
            for (int j = std::max(0, c[1] - 2); j <= std::min(dims[1] - 1, c[1] + 2); ++j)
                for (int k = std::max(0, c[2] - 2); k <= std::min(dims[2] - 1, c[2] + 2); ++k) {
                    const int32_t s = grid[flat(Vec3i(i, j, k))];
                    if (s >= 0 && (samples[s] - x).squaredNorm() < r * r) return false;
                }
        return true;
    };
    grow(shape, samples, active, lo, hi, r, rng, cellOf, clearOf, accept);
    // A file's shape may come in several pieces: seed each piece the growth did not reach, from the centres of
    // the background cells, and grow again. (Analytic shapes are connected; their samples stay as they were.)
    if constexpr (requires { Shape::kMayBeDisconnected; }) {
        for (int i = 0; i < dims[0]; ++i)
            for (int j = 0; j < dims[1]; ++j)
                for (int k = 0; k < dims[2]; ++k) {
                    if (grid[flat(Vec3i(i, j, k))] >= 0) continue;
                    const Vec3d x = lo + (Vec3d(i, j, k) + Vec3d::Constant(0.5)) * cell;
                    if (!shape.contains(x) || !clearOf(x)) continue;
                    accept(x);
                    grow(shape, samples, active, lo, hi, r, rng, cellOf, clearOf, accept);
                }
    }
    return samples;
}

template <class Shape>
std::vector<Vec3d> sampleIn(const Shape& shape, double dx, double particlesPerCell, long long count, Sampling method,
                            unsigned seed) {
    const double perVolume = count > 0 ? double(count) / shape.volume() : particlesPerCell / (dx * dx * dx);
    std::vector<Vec3d> pts;
    if (method != Sampling::Poisson) {
        const double jitter = method == Sampling::Grid ? kGridJitter : 0.0;
        double spacing = std::cbrt(1.0 / perVolume);
        pts = jitteredGrid(shape, spacing, jitter, seed);
        // A sphere may hold slightly fewer lattice points than asked: refine until there are enough.
        while (count > 0 && (long long)pts.size() < count) pts = jitteredGrid(shape, spacing *= 0.97, jitter, seed);
    } else {
        double r = std::cbrt(1.0 / (kPoissonPacking * perVolume));
        pts = poissonDiskIn(shape, r, seed);
        while (count > 0 && (long long)pts.size() < count) pts = poissonDiskIn(shape, r *= 0.95, seed);
    }
    if (count > 0 && (long long)pts.size() > count) {
        std::mt19937 rng(seed ^ 0x9e3779b9u);
        std::shuffle(pts.begin(), pts.end(), rng);
        pts.resize(std::size_t(count));
    }
    return pts;
}

}  // namespace

std::vector<Vec3d> poissonDisk(const SetRegion& shape, double r, unsigned seed) {
    return std::visit([&](const auto& s) { return poissonDiskIn(s, r, seed); }, shape);
}

std::vector<Vec3d> sampleShape(const SetRegion& shape, double dx, double particlesPerCell, long long count, Sampling method,
                               unsigned seed) {
    return std::visit([&](const auto& s) { return sampleIn(s, dx, particlesPerCell, count, method, seed); }, shape);
}

double shapeVolume(const SetRegion& shape) {
    return std::visit([](const auto& s) { return s.volume(); }, shape);
}

}  // namespace mpm
