// OpenVDB-backed sparse grid: leaf topology from particles, leaf release, and the counting sort of particles
// by leaf. Everything here is deterministic: the leaf order comes from the tree's ordered traversal and
// the particle order from a stable counting sort, whatever the number of threads.
#include "sparse/SparseGrid.h"

#include <openvdb/openvdb.h>
#include <openvdb/tools/Prune.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_scan.h>

#include <algorithm>
#include <functional>
#include <limits>

namespace mpm {

namespace {
/// Particles per task when scanning positions; large enough to amortise a tree accessor.
constexpr std::size_t kScanGrain = 4096;
/// Leaves per task in the per-leaf loops (a few tree lookups or chunk sums each).
constexpr std::size_t kLeafGrain = 256;
/// Upper bound on counting-sort chunks: the histogram is chunks x leaves integers.
constexpr std::size_t kMaxSortChunks = 64;
constexpr std::size_t kMinSortChunkSize = 2048;

// Value trees keep OpenVDB's 8^3 leaves with smaller internal nodes than the 5-4-3 default: a 32^3
// internal node costs 0.3-0.5 MB per tree for every occupied 4096^3 region, which would dominate small scenes.
using MassTree = openvdb::tree::Tree4<float, 4, 3, 3>::Type;
using MomentumTree = openvdb::tree::Tree4<openvdb::Vec3s, 4, 3, 3>::Type;
// Coarse trees hold one voxel per grid leaf.
using LeafIndexTree = openvdb::tree::Tree4<int32_t, 3, 3, 3>::Type;
using LeafMaskTree = openvdb::tree::Tree4<openvdb::ValueMask, 3, 3, 3>::Type;

/// Coordinate of the leaf holding a particle's stencil base node (one voxel per leaf in the coarse trees).
openvdb::Coord leafCoordOf(const SparseGrid& grid, const Vec3d& x) {
    const Vec3i b = grid.baseNode(x);
    return openvdb::Coord(b[0] >> kLeafLog2, b[1] >> kLeafLog2, b[2] >> kLeafLog2);
}

/// Collects the set of leaf coordinates (base node >> 3) that hold particles.
struct LeafCollector {
    const std::vector<Vec3d>& x;
    const SparseGrid& grid;
    LeafMaskTree tree;
    LeafCollector(const std::vector<Vec3d>& xs, const SparseGrid& g) : x(xs), grid(g) {}
    LeafCollector(LeafCollector& o, tbb::split) : x(o.x), grid(o.grid) {}
    void operator()(const tbb::blocked_range<std::size_t>& r) {
        openvdb::tree::ValueAccessor<LeafMaskTree> acc(tree);
        // Particles are sorted by leaf from the last substep: runs of one leaf need one tree access.
        openvdb::Coord last(std::numeric_limits<int32_t>::max());
        for (std::size_t i = r.begin(); i < r.end(); ++i) {
            const openvdb::Coord c = leafCoordOf(grid, x[i]);
            if (c == last) continue;
            acc.setValueOn(c);
            last = c;
        }
    }
    void join(LeafCollector& o) { tree.topologyUnion(o.tree); }
};
}  // namespace

struct SparseGrid::Trees {
    MassTree mass{0.0f};
    MomentumTree momentum{openvdb::Vec3s(0.0f)};
    /// One voxel per grid leaf, at its leaf coordinate, holding the leaf's index; two, so that the last
    /// update's index survives the next one (to carry each leaf's written box over).
    LeafIndexTree indexTrees[2] = {LeafIndexTree(-1), LeafIndexTree(-1)};
    LeafIndexTree* leafIndex = &indexTrees[0];
    LeafIndexTree* previousIndex = &indexTrees[1];
    LeafMaskTree particleLeaves;  ///< leaf coordinates that hold particles
    LeafMaskTree gridLeaves;      ///< particle leaves dilated by one towards +x, +y, +z
};

SparseGrid::SparseGrid() : trees_(std::make_unique<Trees>()) { openvdb::initialize(); }
SparseGrid::~SparseGrid() = default;
SparseGrid::SparseGrid(SparseGrid&&) noexcept = default;
SparseGrid& SparseGrid::operator=(SparseGrid&&) noexcept = default;

void SparseGrid::configure(double dx, double baseShift, int stencilWidth) {
    dx_ = dx;
    invDx_ = 1.0 / dx;
    baseShift_ = baseShift;
    stencilWidth_ = stencilWidth;
}

void SparseGrid::updateTopology(const std::vector<BinRequest>& requests) {
    Trees& t = *trees_;

    // 1. Leaves that hold particles (a union of per-task sets; the union does not depend on the split).
    t.particleLeaves.clear();
    for (const BinRequest& r : requests) {
        LeafCollector collect(*r.positions, *this);
        tbb::parallel_reduce(tbb::blocked_range<std::size_t>(0, r.positions->size(), kScanGrain), collect);
        t.particleLeaves.topologyUnion(collect.tree);
    }

    // 2. Grid leaves: a particle's stencil spans at most its own leaf and the next one along each axis,
    //    because the stencil (3 or 4 nodes) is narrower than a leaf (8 nodes).
    t.gridLeaves.clear();
    {
        openvdb::tree::ValueAccessor<LeafMaskTree> acc(t.gridLeaves);
        for (auto it = t.particleLeaves.cbeginValueOn(); it; ++it) {
            const openvdb::Coord c = it.getCoord();
            for (int d = 0; d < 8; ++d) acc.setValueOn(c.offsetBy(d >> 2, (d >> 1) & 1, d & 1));
        }
    }

    // 3. Release value-tree leaves no stencil reaches any more, then allocate the new ones.
    std::vector<openvdb::Coord> stale;
    for (auto it = t.mass.cbeginLeaf(); it; ++it) {
        const openvdb::Coord o = it->origin();
        if (!t.gridLeaves.isValueOn(openvdb::Coord(o.x() >> kLeafLog2, o.y() >> kLeafLog2, o.z() >> kLeafLog2)))
            stale.push_back(o);
    }
    for (const openvdb::Coord& o : stale) {
        t.mass.addTile(1, o, 0.0f, false);
        t.momentum.addTile(1, o, openvdb::Vec3s(0.0f), false);
    }
    if (!stale.empty()) {  // collapse internal nodes left without leaves
        openvdb::tools::pruneInactive(t.mass);
        openvdb::tools::pruneInactive(t.momentum);
    }

    // Keep the old index and boxes, to hand each surviving leaf its box (a new leaf is all zero).
    std::swap(t.leafIndex, t.previousIndex);
    writtenBefore_.swap(written_);
    t.leafIndex->clear();
    leaves_.clear();
    hasParticles_.clear();
    {
        openvdb::tree::ValueAccessor<LeafIndexTree> idx(*t.leafIndex);
        openvdb::tree::ValueAccessor<MassTree> massAcc(t.mass);
        openvdb::tree::ValueAccessor<MomentumTree> momAcc(t.momentum);
        for (auto it = t.gridLeaves.cbeginValueOn(); it; ++it) {
            const openvdb::Coord c = it.getCoord();
            const openvdb::Coord origin(c.x() << kLeafLog2, c.y() << kLeafLog2, c.z() << kLeafLog2);
            idx.setValue(c, int32_t(leaves_.size()));
            auto* m = massAcc.touchLeaf(origin);
            auto* p = momAcc.touchLeaf(origin);
            m->setValuesOn();  // active voxels keep the leaf alive through pruneInactive
            p->setValuesOn();
            LeafView view;
            view.mass = m->buffer().data();
            view.momentum = reinterpret_cast<float*>(p->buffer().data());
            view.origin = Vec3i(origin.x(), origin.y(), origin.z());
            leaves_.push_back(view);
            hasParticles_.push_back(t.particleLeaves.isValueOn(c) ? 1 : 0);
        }
    }
    const std::size_t L = leaves_.size();

    // 4. Particle leaves, their 8 neighbours (looked up once per leaf, not per particle) and the inverse.
    particleLeaves_.clear();
    for (uint32_t l = 0; l < L; ++l)
        if (hasParticles_[l]) particleLeaves_.push_back(l);
    neighbours_.resize(L);
    sources_.resize(L);
    written_.resize(L);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, L, kLeafGrain), [&](const tbb::blocked_range<std::size_t>& range) {
        openvdb::tree::ValueAccessor<const LeafIndexTree> before(*t.previousIndex);
        for (std::size_t l = range.begin(); l < range.end(); ++l) {
            sources_[l].fill(kNoLeaf);
            const Vec3i c = leaves_[l].origin / kLeafDim;
            const int32_t old = before.getValue(openvdb::Coord(c[0], c[1], c[2]));
            written_[l] = old >= 0 ? writtenBefore_[old] : NodeBox{};
        }
    });
    // The tree lookups, the costly part, in parallel (read-only accessors, one per task). Each (leaf, d)
    // of the inverse has one source, so the tasks write disjoint entries.
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particleLeaves_.size(), kLeafGrain),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                          openvdb::tree::ValueAccessor<const LeafIndexTree> idx(*t.leafIndex);
                          for (std::size_t i = range.begin(); i < range.end(); ++i) {
                              const uint32_t l = particleLeaves_[i];
                              const Vec3i c = leaves_[l].origin / kLeafDim;
                              for (int d = 0; d < 8; ++d) {
                                  const uint32_t n = uint32_t(
                                      idx.getValue(openvdb::Coord(c[0] + (d >> 2), c[1] + ((d >> 1) & 1), c[2] + (d & 1))));
                                  neighbours_[l][d] = n;
                                  sources_[n][d] = uint32_t(i);
                              }
                          }
                      });
}

void SparseGrid::sortParticles(std::vector<BinRequest>& requests) {
    const Trees& t = *trees_;
    const std::size_t L = leaves_.size();
    // Stable counting sort of each species by leaf.
    for (BinRequest& r : requests) {
        const std::vector<Vec3d>& x = *r.positions;
        const std::size_t N = x.size();
        r.destination->resize(N);
        r.leafStart->assign(L + 1, 0);
        if (N == 0) continue;
        const std::size_t chunks = std::clamp<std::size_t>(N / kMinSortChunkSize, 1, kMaxSortChunks);
        const std::size_t chunkSize = (N + chunks - 1) / chunks;
        histogram_.assign(chunks * L, 0);
        // The destination array first holds each particle's leaf, then (in place) its sorted slot.
        std::vector<uint32_t>& dest = *r.destination;
        tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
            openvdb::tree::ValueAccessor<const LeafIndexTree> idx(*t.leafIndex);
            uint32_t* hist = histogram_.data() + c * L;
            const std::size_t end = std::min(N, (c + 1) * chunkSize);
            openvdb::Coord last(std::numeric_limits<int32_t>::max());
            uint32_t l = 0;
            for (std::size_t i = c * chunkSize; i < end; ++i) {
                const openvdb::Coord leafCoord = leafCoordOf(*this, x[i]);
                if (leafCoord != last) {  // as above, runs of one leaf share one lookup
                    l = uint32_t(idx.getValue(leafCoord));
                    last = leafCoord;
                }
                dest[i] = l;
                ++hist[l];
            }
        });
        // Exclusive prefix over (leaf, chunk): chunk c of leaf l starts after all earlier chunks of l.
        // In parallel, since it grows with the leaf count: per-leaf totals, a scan over leaves, then each
        // leaf's chunks from its start.
        std::vector<uint32_t>& start = *r.leafStart;
        leafCount_.resize(L);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, L, kLeafGrain), [&](const tbb::blocked_range<std::size_t>& range) {
            for (std::size_t l = range.begin(); l < range.end(); ++l) {
                uint32_t n = 0;
                for (std::size_t c = 0; c < chunks; ++c) n += histogram_[c * L + l];
                leafCount_[l] = n;
            }
        });
        start[L] = tbb::parallel_scan(
            tbb::blocked_range<std::size_t>(0, L, kLeafGrain), uint32_t(0),
            [&](const tbb::blocked_range<std::size_t>& range, uint32_t sum, bool final) {
                for (std::size_t l = range.begin(); l < range.end(); ++l) {
                    if (final) start[l] = sum;
                    sum += leafCount_[l];
                }
                return sum;
            },
            std::plus<uint32_t>());
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, L, kLeafGrain), [&](const tbb::blocked_range<std::size_t>& range) {
            for (std::size_t l = range.begin(); l < range.end(); ++l) {
                uint32_t running = start[l];
                for (std::size_t c = 0; c < chunks; ++c) {
                    const uint32_t n = histogram_[c * L + l];
                    histogram_[c * L + l] = running;
                    running += n;
                }
            }
        });
        tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
            uint32_t* next = histogram_.data() + c * L;
            const std::size_t end = std::min(N, (c + 1) * chunkSize);
            for (std::size_t i = c * chunkSize; i < end; ++i) dest[i] = next[dest[i]]++;
        });
    }
}

std::size_t SparseGrid::memoryBytes() const {
    const Trees& t = *trees_;
    return std::size_t(t.mass.memUsage() + t.momentum.memUsage() + t.leafIndex->memUsage() + t.particleLeaves.memUsage() +
                       t.gridLeaves.memUsage()) +
           leaves_.capacity() * sizeof(LeafView) + neighbours_.capacity() * sizeof(std::array<uint32_t, 8>) +
           sources_.capacity() * sizeof(std::array<uint32_t, 8>) + transferScratch_.capacity() * sizeof(float) +
           (written_.capacity() + writtenBefore_.capacity()) * sizeof(NodeBox) + std::size_t(t.previousIndex->memUsage()) +
           histogram_.capacity() * sizeof(uint32_t) +
           leafCount_.capacity() * sizeof(uint32_t);
}

std::size_t SparseGrid::allocatedLeaves() const { return std::size_t(trees_->mass.leafCount()); }

}  // namespace mpm
