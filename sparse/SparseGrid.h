#pragma once
// The background grid: nodes live in the 8x8x8 leaves of two OpenVDB trees (mass: float; momentum, then
// velocity: Vec3s) that share one topology. A leaf exists only where some particle's stencil reaches and
// is released when none does, so the domain is unbounded and memory follows the occupied volume.
// OpenVDB stays inside SparseGrid.cpp: this header exposes raw leaf buffers only. The grid knows positions
// and nodes, never materials or species: binning sorts index arrays that the caller applies.
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "sparse/LeafGeometry.h"

namespace mpm {

/// What binning needs to know about one group of particles (a species), and what it hands back.
struct BinRequest {
    const std::vector<Vec3d>* positions = nullptr;  ///< in: particle positions
    const std::vector<int32_t>* ids = nullptr;      ///< in: particle ids, the order inside a leaf
    std::vector<uint32_t>* destination = nullptr;   ///< out: sorted slot of each particle
    std::vector<uint32_t>* leafStart = nullptr;     ///< out: leafCount()+1 offsets
};

class SparseGrid {
public:
    SparseGrid();
    ~SparseGrid();
    SparseGrid(const SparseGrid&) = delete;
    SparseGrid& operator=(const SparseGrid&) = delete;
    SparseGrid(SparseGrid&&) noexcept;
    SparseGrid& operator=(SparseGrid&&) noexcept;

    /// Sets the spacing and the stencil: base node = floor(x / dx - baseShift), stencil width nodes per axis.
    void configure(double dx, double baseShift, int stencilWidth) { geometry_ = StencilGeometry(dx, baseShift, stencilWidth); }
    double dx() const { return geometry_.dx; }
    const StencilGeometry& geometry() const { return geometry_; }

    /// Bins all particles by the leaf holding their stencil's base node, allocates the leaves their
    /// stencils reach (own leaf plus the +x/+y/+z neighbours they spill into), releases the rest, and returns, for every
    /// species, a stable counting-sort permutation and each leaf's particle range.
    void rebuild(std::vector<BinRequest>& requests) {
        updateTopology(requests);
        sortParticles(requests);
    }
    /// The first half of rebuild: the leaf set and its neighbour tables ("topology update"); collectLeaves
    /// then allocateLeaves.
    void updateTopology(const std::vector<BinRequest>& requests) {
        collectLeaves(requests);
        allocateLeaves();
    }
    /// The leaves that hold particles and the leaves their stencils reach.
    void collectLeaves(const std::vector<BinRequest>& requests);
    /// The leaf coordinates collectLeaves found reached (particle leaves included), in leaf order.
    std::vector<Vec3i> reachedLeaves() const;
    /// Adds leaves (by leaf coordinate) that stencils of particles held elsewhere reach (another rank's).
    void addReachedLeaves(const std::vector<Vec3i>& leafCoords);
    /// Allocates the collected leaves in leaf order (Morton, LeafGeometry.h), releases the others, and builds
    /// the neighbour tables.
    void allocateLeaves();
    /// The second half: the counting sort of each species by leaf ("binning"), particles of one leaf in id
    /// order, so that the order is a function of the leaves and ids alone; needs updateTopology first.
    void sortParticles(std::vector<BinRequest>& requests);
    /// The index of the leaf at a leaf coordinate, or kNoLeaf (safe to call from many threads).
    uint32_t indexOfLeaf(const Vec3i& leafCoord) const;

    std::size_t leafCount() const { return leaves_.size(); }
    const LeafView& leaf(std::size_t i) const { return leaves_[i]; }
    /// All leaves holding particles, in leaf order.
    const std::vector<uint32_t>& particleLeaves() const { return particleLeaves_; }
    /// The 8 leaves at leaf coordinate + {0,1}^3 of a particle leaf (numbered as in LeafGeometry.h); kNoLeaf
    /// for a neighbour that none of its particles' stencils reaches (it is not allocated).
    const std::array<uint32_t, kNeighbours>& neighbours(std::size_t leafIndex) const { return neighbours_[leafIndex]; }
    /// The inverse: for any leaf, entry d is the position in particleLeaves() of the particle leaf whose
    /// neighbours()[d] it is (the one at leaf coordinate - offset d), or kNoLeaf.
    static constexpr uint32_t kNoLeaf = ~0u;
    const std::array<uint32_t, kNeighbours>& sources(std::size_t leafIndex) const { return sources_[leafIndex]; }
    /// The nodes of leaf i that P2G wrote (the grid update and G2P touch no others); every node outside
    /// is zero. A leaf that lives on keeps its box through updateTopology, so that the next P2G zeroes only
    /// that box: a lone particle then costs its stencil, not the 8 leaves (4096 nodes) the stencil touches.
    NodeBox& writtenBox(std::size_t i) { return written_[i]; }
    const NodeBox& writtenBox(std::size_t i) const { return written_[i]; }
    /// Workspace of the transfers, kept between substeps so that it is allocated once.
    std::vector<float>& transferScratch() { return transferScratch_; }

    /// Bytes held by the grid trees, the leaf tables and the workspace (capacities: what the process holds).
    std::size_t memoryBytes() const;
    /// Bytes of the grid's leaves (mass and momentum) and per-leaf tables: a function of the particles' places
    /// alone, not of the run's history (stats.csv reports it, and a resumed run must report the same).
    std::size_t contentBytes() const;
    /// contentBytes() per leaf.
    static std::size_t bytesPerLeaf();
    /// Number of leaves allocated in the trees (equals leafCount() after rebuild).
    std::size_t allocatedLeaves() const;

    /// Base node of a particle's stencil.
    Vec3i baseNode(const Vec3d& x) const { return geometry_.baseNode(x); }

private:
    struct Trees;
    std::unique_ptr<Trees> trees_;
    StencilGeometry geometry_;
    std::vector<LeafView> leaves_;
    std::vector<uint32_t> particleLeaves_;
    std::vector<std::array<uint32_t, kNeighbours>> neighbours_;
    std::vector<std::array<uint32_t, kNeighbours>> sources_;
    std::vector<NodeBox> written_, writtenBefore_;
    std::vector<float> transferScratch_;
    std::vector<uint32_t> histogram_;
    std::vector<uint32_t> leafCount_;  ///< particles per leaf, for the parallel prefix sum
    std::vector<uint8_t> hasParticles_;
    std::vector<uint32_t> slotOwner_;  ///< sortParticles: the particle at each sorted slot
};

}  // namespace mpm
