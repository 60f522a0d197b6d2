// OpenVDB-backed sparse grid: leaf topology from particles, leaf release, and the counting sort of particles
// by leaf. Everything here is deterministic: leaves in Morton order, the particles of a leaf in id order,
// whatever the number of threads (or of ranks that each hold a part of the leaves).
#include "sparse/SparseGrid.h"

#include <openvdb/openvdb.h>
#include <openvdb/tools/Prune.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <limits>

#include "sparse/LeafParallel.h"

namespace mpm {

namespace {
/// Particles per task when scanning positions; large enough to amortise a tree accessor.
constexpr std::size_t kScanGrain = 4096;
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

openvdb::Coord toCoord(const Vec3i& c) { return openvdb::Coord(c[0], c[1], c[2]); }

/// Coordinate of the leaf holding a particle's stencil base node (one voxel per leaf in the coarse trees).
openvdb::Coord leafCoordOf(const SparseGrid& grid, const Vec3d& x) { return toCoord(leafOfNode(grid.baseNode(x))); }

/// The leaf at leaf coordinate c + neighbour d.
openvdb::Coord neighbourCoord(const openvdb::Coord& c, int d) {
    return c.offsetBy(neighbourStep(d, 0), neighbourStep(d, 1), neighbourStep(d, 2));
}

/// For each spill pattern s (the neighbour that holds a stencil's far corner), the neighbours that stencil
/// reaches: every d whose steps lie inside s's.
constexpr std::array<uint8_t, kNeighbours> reachedNeighbours() {
    std::array<uint8_t, kNeighbours> m{};
    for (int spill = 0; spill < kNeighbours; ++spill)
        for (int d = 0; d < kNeighbours; ++d)
            if ((d & ~spill) == 0) m[spill] |= uint8_t(1u << d);
    return m;
}

/// Collects the leaves that hold particles (by their stencil's base node) and the leaves the stencils
/// reach: a particle's own leaf and, along each axis where its stencil runs past the leaf's last node, the
/// next one. A lone particle so needs about 2 leaves on average instead of all 8 around it.
struct LeafCollector {
    const std::vector<Vec3d>& x;
    const SparseGrid& grid;
    int width;
    LeafMaskTree particles, reached;
    LeafCollector(const std::vector<Vec3d>& xs, const SparseGrid& g, int w) : x(xs), grid(g), width(w) {}
    LeafCollector(LeafCollector& o, tbb::split) : x(o.x), grid(o.grid), width(o.width) {}
    void operator()(const tbb::blocked_range<std::size_t>& r) {
        static constexpr std::array<uint8_t, kNeighbours> kReached = reachedNeighbours();
        constexpr unsigned kAllNeighbours = 0xFF;
        openvdb::tree::ValueAccessor<LeafMaskTree> own(particles), all(reached);
        // Particles are sorted by leaf from the last substep: a run of one leaf is entered once, with the
        // neighbours its stencils reach gathered in a register (no call inside the run's loop).
        std::size_t i = r.begin();
        Vec3i b = i < r.end() ? grid.baseNode(x[i]) : Vec3i::Zero();
        while (i < r.end()) {
            const Vec3i leaf = leafOfNode(b);
            unsigned mask = 0;
            do {
                if (mask != kAllNeighbours) mask |= kReached[farCornerNeighbour(b, width)];  // in bulk a run saturates early
                if (++i == r.end()) break;
                b = grid.baseNode(x[i]);
            } while (nodeInLeaf(b, leaf));
            enter(own, all, toCoord(leaf), mask);
        }
    }
    /// Marks leaf c as holding particles and the neighbours in mask as reached.
    static void enter(openvdb::tree::ValueAccessor<LeafMaskTree>& own, openvdb::tree::ValueAccessor<LeafMaskTree>& all,
                      const openvdb::Coord& c, unsigned mask) {
        if (mask == 0) return;
        own.setValueOn(c);
        for (int d = 0; d < kNeighbours; ++d)
            if (mask >> d & 1u) all.setValueOn(neighbourCoord(c, d));
    }
    void join(LeafCollector& o) {
        particles.topologyUnion(o.particles);
        reached.topologyUnion(o.reached);
    }
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
    LeafMaskTree gridLeaves;      ///< leaves some particle's stencil reaches
};

SparseGrid::SparseGrid() : trees_(std::make_unique<Trees>()) { openvdb::initialize(); }
SparseGrid::~SparseGrid() = default;
SparseGrid::SparseGrid(SparseGrid&&) noexcept = default;
SparseGrid& SparseGrid::operator=(SparseGrid&&) noexcept = default;

void SparseGrid::collectLeaves(const std::vector<BinRequest>& requests) {
    Trees& t = *trees_;
    // 1. Leaves that hold particles, and the leaves their stencils reach (unions of per-task sets; a union
    //    does not depend on the split). A stencil (3 or 4 nodes) is narrower than a leaf (8 nodes), so it
    //    spans at most its own leaf and the next one along each axis.
    t.particleLeaves.clear();
    t.gridLeaves.clear();
    for (const BinRequest& r : requests) {
        LeafCollector collect(*r.positions, *this, geometry_.width);
        tbb::parallel_reduce(tbb::blocked_range<std::size_t>(0, r.positions->size(), kScanGrain), collect);
        t.particleLeaves.topologyUnion(collect.particles);
        t.gridLeaves.topologyUnion(collect.reached);
    }
}

std::vector<Vec3i> SparseGrid::reachedLeaves() const {
    std::vector<Vec3i> out;
    for (auto it = trees_->gridLeaves.cbeginValueOn(); it; ++it) {
        const openvdb::Coord c = it.getCoord();
        out.emplace_back(c.x(), c.y(), c.z());
    }
    tbb::parallel_sort(out.begin(), out.end(), mortonLess);
    return out;
}

void SparseGrid::addReachedLeaves(const std::vector<Vec3i>& leafCoords) {
    openvdb::tree::ValueAccessor<LeafMaskTree> all(trees_->gridLeaves);
    for (const Vec3i& c : leafCoords) all.setValueOn(toCoord(c));
}

uint32_t SparseGrid::indexOfLeaf(const Vec3i& leafCoord) const {
    return uint32_t(trees_->leafIndex->getValue(toCoord(leafCoord)));
}

void SparseGrid::allocateLeaves() {
    Trees& t = *trees_;
    // 2. Release value-tree leaves no stencil reaches any more, then allocate the new ones.
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
        // Leaves in Morton order (the tree's own traversal is x-major inside each internal node): the order a
        // domain is cut into ranks' ranges, so that the ranks' particles, one after another, are one process's.
        for (const Vec3i& leafCoord : reachedLeaves()) {
            const openvdb::Coord c = toCoord(leafCoord);
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

    // 3. Particle leaves, their 8 neighbours (looked up once per leaf, not per particle) and the inverse.
    particleLeaves_.clear();
    for (uint32_t l = 0; l < L; ++l)
        if (hasParticles_[l]) particleLeaves_.push_back(l);
    neighbours_.resize(L);
    sources_.resize(L);
    written_.resize(L);
    forEachLeafRange(L, LeafGrain::Bookkeeping, [&](std::size_t begin, std::size_t end) {
        openvdb::tree::ValueAccessor<const LeafIndexTree> before(*t.previousIndex);
        for (std::size_t l = begin; l < end; ++l) {
            sources_[l].fill(kNoLeaf);
            const int32_t old = before.getValue(toCoord(leafOfNode(leaves_[l].origin)));
            written_[l] = old >= 0 ? writtenBefore_[old] : NodeBox{};
        }
    });
    // The tree lookups, the costly part, in parallel (read-only accessors, one per task). Each (leaf, d)
    // of the inverse has one source, so the tasks write disjoint entries.
    forEachLeafRange(particleLeaves_.size(), LeafGrain::Bookkeeping, [&](std::size_t begin, std::size_t end) {
        openvdb::tree::ValueAccessor<const LeafIndexTree> idx(*t.leafIndex);
        for (std::size_t i = begin; i < end; ++i) {
            const uint32_t l = particleLeaves_[i];
            const openvdb::Coord c = toCoord(leafOfNode(leaves_[l].origin));
            for (int d = 0; d < kNeighbours; ++d) {
                const uint32_t n = uint32_t(idx.getValue(neighbourCoord(c, d)));
                neighbours_[l][d] = n;  // kNoLeaf where no stencil of this leaf reaches
                if (n != kNoLeaf) sources_[n][d] = uint32_t(i);
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
        forEachLeaf(L, LeafGrain::Bookkeeping, [&](std::size_t l) {
            uint32_t n = 0;
            for (std::size_t c = 0; c < chunks; ++c) n += histogram_[c * L + l];
            leafCount_[l] = n;
        });
        start[L] = prefixSumOverLeaves<uint32_t>(
            L, [&](std::size_t l) { return leafCount_[l]; }, [&](std::size_t l, uint32_t sum) { start[l] = sum; });
        forEachLeaf(L, LeafGrain::Bookkeeping, [&](std::size_t l) {
            uint32_t running = start[l];
            for (std::size_t c = 0; c < chunks; ++c) {
                const uint32_t n = histogram_[c * L + l];
                histogram_[c * L + l] = running;
                running += n;
            }
        });
        tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
            uint32_t* next = histogram_.data() + c * L;
            const std::size_t end = std::min(N, (c + 1) * chunkSize);
            for (std::size_t i = c * chunkSize; i < end; ++i) dest[i] = next[dest[i]]++;
        });
        // Inside a leaf, particles by id: the stable sort keeps the order they came in, which on several ranks
        // depends on where each came from. A leaf that no particle entered is in id order already.
        const std::vector<int32_t>& id = *r.ids;
        slotOwner_.resize(N);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, N, kScanGrain), [&](const auto& range) {
            for (std::size_t i = range.begin(); i < range.end(); ++i) slotOwner_[dest[i]] = uint32_t(i);
        });
        forEachLeaf(L, LeafGrain::Particles, [&](std::size_t l) {
            uint32_t* first = slotOwner_.data() + start[l];
            uint32_t* last = slotOwner_.data() + start[l + 1];
            auto byId = [&](uint32_t a, uint32_t b) { return id[a] < id[b]; };
            if (std::is_sorted(first, last, byId)) return;
            std::sort(first, last, byId);
            for (uint32_t* s = first; s != last; ++s) dest[*s] = start[l] + uint32_t(s - first);
        });
    }
}

std::size_t SparseGrid::memoryBytes() const {
    const Trees& t = *trees_;
    return std::size_t(t.mass.memUsage() + t.momentum.memUsage() + t.leafIndex->memUsage() + t.particleLeaves.memUsage() +
                       t.gridLeaves.memUsage()) +
           leaves_.capacity() * sizeof(LeafView) + neighbours_.capacity() * sizeof(std::array<uint32_t, kNeighbours>) +
           sources_.capacity() * sizeof(std::array<uint32_t, kNeighbours>) + transferScratch_.capacity() * sizeof(float) +
           (written_.capacity() + writtenBefore_.capacity()) * sizeof(NodeBox) + std::size_t(t.previousIndex->memUsage()) +
           (histogram_.capacity() + slotOwner_.capacity()) * sizeof(uint32_t) + leafCount_.capacity() * sizeof(uint32_t);
}

std::size_t SparseGrid::bytesPerLeaf() {
    // A leaf node holds its values in a buffer of its own: 512 masses and 512 momenta beside the node.
    return sizeof(MassTree::LeafNodeType) + sizeof(MomentumTree::LeafNodeType) + MassTree::LeafNodeType::SIZE * sizeof(float) +
           MomentumTree::LeafNodeType::SIZE * sizeof(openvdb::Vec3s) + sizeof(LeafView) +
           2 * sizeof(std::array<uint32_t, kNeighbours>) + 2 * sizeof(NodeBox);
}

std::size_t SparseGrid::contentBytes() const {
    // From the leaf count alone, so that the number depends on where the particles are, not on the history
    // of the trees and buffers (a resumed run reports what an uninterrupted one does).
    return leaves_.size() * bytesPerLeaf();
}

std::size_t SparseGrid::allocatedLeaves() const { return std::size_t(trees_->mass.leafCount()); }

}  // namespace mpm
