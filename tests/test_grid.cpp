// The sparse grid: leaves only where particles are, released when they leave, memory independent of
// the distance between occupied regions.
#include <gtest/gtest.h>

#include "TestScenes.h"

using namespace mpm;
using namespace mpm::test;

namespace {
struct GridSize {
    std::size_t leaves, bytes;
};

GridSize twoBlobs(double gapCells) {
    SimulationSettings s;
    s.dx = 0.1;
    s.gravity = Vec3d::Zero();
    Simulation sim(s);
    const Vec3d size(0.8, 0.8, 0.8);
    addWaterBlock(sim, Vec3d::Zero(), size);
    const Vec3d far(gapCells * s.dx, 0, 0);
    addWaterBlock(sim, far, far + size);
    sim.substep(1e-4);
    EXPECT_EQ(sim.grid().allocatedLeaves(), sim.grid().leafCount());
    return {sim.grid().leafCount(), sim.grid().memoryBytes()};
}
}  // namespace

TEST(SparseGrid, FarBlobsAllocateWhatNearBlobsDo) {
    const GridSize near = twoBlobs(64), far = twoBlobs(1e5), farther = twoBlobs(1e6);
    EXPECT_EQ(near.leaves, far.leaves);
    EXPECT_EQ(far.leaves, farther.leaves);
    // A distant region costs its own upper tree nodes once, never memory proportional to the gap.
    // 10x the gap costs at most a few upper tree nodes (alignment of the coarse trees), never memory in
    // proportion to the 900,000 empty cells in between.
    constexpr double kUpperNodesSlack = 256.0 * 1024;
    EXPECT_NEAR(double(far.bytes), double(farther.bytes), kUpperNodesSlack);
    EXPECT_LT(double(far.bytes), double(near.bytes) + 4 * kUpperNodesSlack);
}

TEST(SparseGrid, LeavesFollowTheParticles) {
    SimulationSettings s;
    s.dx = 0.1;
    s.gravity = Vec3d::Zero();
    s.adaptive = false;
    s.stability.cellCrossing = false;  // a rigid translation of 4 cells per substep, to move the leaves fast
    Simulation sim(s);
    addWaterBlock(sim, Vec3d::Zero(), Vec3d(0.4, 0.4, 0.4), Vec3f(100.0f, 0.0f, 0.0f));
    sim.substep(1e-4);
    const std::size_t leaves = sim.grid().leafCount();
    // Travel 200 cells in 50 substeps: the grid moves with the blob and its size stays the same.
    for (int n = 0; n < 50; ++n) sim.substep(4e-3);
    EXPECT_EQ(sim.grid().leafCount(), sim.grid().allocatedLeaves());
    EXPECT_LE(sim.grid().leafCount(), leaves);
    EXPECT_NEAR(particlesOf(sim.species()[0]).x[0][0], 20.0 + 0.025, 0.05);
    for (std::size_t l = 0; l < sim.grid().leafCount(); ++l) EXPECT_GT(sim.grid().leaf(l).origin[0], 150);
}

TEST(SparseGrid, EveryParticleIsBinnedInsideItsLeaf) {
    SimulationSettings s;
    s.dx = 0.1;
    Simulation sim(s);
    addWaterBlock(sim, Vec3d(-1.05, -0.3, 0.2), Vec3d(0.7, 0.35, 1.1));
    sim.substep(1e-4);
    const auto& sp = std::get<Species<Water>>(sim.species()[0]);
    std::size_t counted = 0;
    for (std::size_t l = 0; l < sim.grid().leafCount(); ++l)
        for (uint32_t p = sp.leafStart[l]; p < sp.leafStart[l + 1]; ++p) {
            // Binning happens before advection, so use the base node of the position at binning time.
            ++counted;
            (void)p;
        }
    EXPECT_EQ(counted, sp.size());
    // Rebin at rest and check each particle's base node lies inside its leaf.
    s.gravity = Vec3d::Zero();
    Simulation still(s);
    addWaterBlock(still, Vec3d(-1.05, -0.3, 0.2), Vec3d(0.7, 0.35, 1.1));
    still.substep(0.0);
    const auto& st = std::get<Species<Water>>(still.species()[0]);
    for (std::size_t l = 0; l < still.grid().leafCount(); ++l)
        for (uint32_t p = st.leafStart[l]; p < st.leafStart[l + 1]; ++p) {
            const Vec3i rel = still.grid().baseNode(st.p.x[p]) - still.grid().leaf(l).origin;
            EXPECT_TRUE(rel.minCoeff() >= 0 && rel.maxCoeff() < kLeafDim);
        }
}

TEST(SparseGrid, NodesOutsideTheWrittenBoxesStayZeroAsSprayMoves) {
    // P2G zeroes only what the last substep wrote in a leaf that lives on. If that bookkeeping slipped,
    // last substep's values would survive into this one's sums: the grid's mass would exceed the particles'.
    SimulationSettings s;
    s.dx = 0.1;
    s.gravity = Vec3d(0, -9.81, 0);
    Simulation sim(s);
    // A block (whole leaves) and lone particles flying apart at up to half a cell per substep, so that
    // they move through their leaves and into new ones while the old leaves still hold last step's values.
    addWaterBlock(sim, Vec3d::Zero(), Vec3d(0.8, 0.8, 0.8));
    Species<Water> spray;
    spray.name = "spray";
    const int id = sim.addSpecies(std::move(spray));
    std::vector<Vec3d> lone;
    std::vector<Vec3f> velocity;
    for (int i = 0; i < 6; ++i) lone.emplace_back(2.0 + 1.7 * i, 0.33 + 0.1 * i, 0.05 * i);
    const double vol = 0.125 * s.dx * s.dx * s.dx;
    for (std::size_t i = 0; i < lone.size(); ++i)
        sim.addParticles(id, {lone[i]}, Vec3f(float(i % 3) - 1.0f, 1.0f - float(i % 2) * 2.0f, 0.5f) * 40.0f, float(vol * 1000.0),
                         float(vol), 0);
    const double particleMass = sim.measure().mass;
    for (int step = 0; step < 40; ++step) {
        sim.substep(1e-3);
        double gridMass = 0.0;
        std::size_t strayNodes = 0;
        for (std::size_t l = 0; l < sim.grid().leafCount(); ++l) {
            const LeafView& leaf = sim.grid().leaf(l);
            std::vector<char> inBox(kLeafNodes, 0);
            sim.grid().writtenBox(l).forEach([&](int n) { inBox[n] = 1; });
            for (int n = 0; n < kLeafNodes; ++n) {
                gridMass += leaf.mass[n];
                const bool zero = leaf.mass[n] == 0.0f && leaf.momentum[3 * n] == 0.0f && leaf.momentum[3 * n + 1] == 0.0f &&
                                  leaf.momentum[3 * n + 2] == 0.0f;
                if (!inBox[n] && !zero) ++strayNodes;
            }
        }
        ASSERT_EQ(strayNodes, 0u) << "substep " << step;
        ASSERT_NEAR(gridMass, particleMass, 1e-5 * particleMass) << "substep " << step;
    }
}

TEST(SparseGrid, ALoneParticleAllocatesOnlyTheLeavesItsStencilReaches) {
    // The quadratic stencil covers base .. base + 2 per axis: it spills into the next leaf only from the
    // last two node positions of a leaf. One particle in the middle of a leaf needs that leaf alone; one
    // in a corner needs all 8 around it.
    auto leavesFor = [](const Vec3d& x) {
        SimulationSettings s;
        s.dx = 0.1;
        s.gravity = Vec3d::Zero();
        Simulation sim(s);
        Species<Water> w;
        w.name = "water";
        const int id = sim.addSpecies(std::move(w));
        sim.addParticles(id, {x}, Vec3f::Zero(), 1e-3f, 1e-6f, 0);
        sim.substep(1e-4);
        EXPECT_EQ(sim.grid().leafCount(), sim.grid().allocatedLeaves());
        return sim.grid().leafCount();
    };
    // Base node floor(x / dx - 0.5): x = 0.35 gives base 3 (nodes 3..5), x = 0.75 gives base 7 (7..9).
    EXPECT_EQ(leavesFor(Vec3d(0.35, 0.35, 0.35)), 1u);
    EXPECT_EQ(leavesFor(Vec3d(0.75, 0.35, 0.35)), 2u);
    EXPECT_EQ(leavesFor(Vec3d(0.75, 0.75, 0.35)), 4u);
    EXPECT_EQ(leavesFor(Vec3d(0.75, 0.75, 0.75)), 8u);
}
