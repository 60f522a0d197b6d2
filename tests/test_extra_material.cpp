// A material defined outside the engine (tests/LinearElastic.h) joins by its header and one list entry: this
// executable builds the engine and the scene reader with MPM_EXTRA_MATERIALS=,LinearElastic (tests/
// CMakeLists.txt), and a scene then uses it by name, with its keys checked, documented and run.
#include <gtest/gtest.h>

#include <cstdio>
#include <random>

#include "io/SceneBuilder.h"
#include "io/SceneReader.h"

using namespace mpm;

TEST(ExtraMaterial, JoinsScenesAndTheFormatByItsHeaderAndOneListEntry) {
    const SceneDesc scene = parseScene(R"({
      "simulation": { "dx": 0.05 },
      "sets": [ { "material": "linear", "material_params": { "youngs_modulus": 2e5, "poisson_ratio": 0.25 },
                  "shape": { "type": "box", "min": [0, 0, 0], "max": [0.2, 0.2, 0.2] } } ] })",
                                       "linear.json");
    EXPECT_NE(scene.resolvedJson.find("\"youngs_modulus\": 200000"), std::string::npos) << scene.resolvedJson;
    auto sim = buildSimulation(scene);
    const auto& sp = std::get<Species<LinearElastic>>(sim->species().at(0));
    const Lame l = Lame::fromYoung(2e5, 0.25);
    EXPECT_EQ(sp.params.mu, l.mu);
    EXPECT_EQ(sp.params.lambda, l.lambda);
    const std::string format = explainSceneFormat();
    EXPECT_NE(format.find("**linear** (`linear_elastic`)"), std::string::npos);
    EXPECT_NE(format.find("jelly, rubber, snow, sand, metal, viscous, linear"), std::string::npos);
    try {
        parseScene(
            R"({"sets":[{"material":"linear","material_params":{"bulk_modulus":1},"shape":{"type":"box","min":[0,0,0],"max":[1,1,1]}}]})",
            "bad.json");
        FAIL() << "an unknown key of the new material was accepted";
    } catch (const SceneError& e) {
        EXPECT_NE(std::string(e.what()).find(
                      "bad.json: /sets/0/material_params/bulk_modulus: unknown key; known here: density, youngs_modulus"),
                  std::string::npos)
            << e.what();
    }
}

TEST(ExtraMaterial, StressIsTheEnergyGradientAndAReleasedBlockKeepsItsEnergy) {
    // P = dPsi/dF by central differences, as for the engine's own models.
    const double mu = 3e4, lambda = 5e4, h = 1e-6;
    std::mt19937 rng(4);
    std::uniform_real_distribution<double> u(-0.2, 0.2);
    Mat3d F = Mat3d::Identity();
    for (int i = 0; i < 9; ++i) F(i / 3, i % 3) += u(rng);
    const Mat3d P = LinearElastic::piola<double>(mu, lambda, F);
    for (int i = 0; i < 9; ++i) {
        Mat3d a = F, b = F;
        a(i / 3, i % 3) += h;
        b(i / 3, i % 3) -= h;
        const double fd = (LinearElastic::psi<double>(mu, lambda, a) - LinearElastic::psi<double>(mu, lambda, b)) / (2 * h);
        EXPECT_NEAR(P(i / 3, i % 3), fd, 1e-6 * mu);
    }
    // A block stretched by 2% along x and let go, without gravity: it rings about its rest shape. Momentum
    // stays zero and the stored energy turns into motion and back without being created.
    SceneDesc scene = parseScene(R"({
      "simulation": { "dx": 0.05, "gravity": [0, 0, 0], "substeps": 10 },
      "sets": [ { "material": "linear", "sampling": "lattice",
                  "shape": { "type": "box", "min": [0, 0, 0], "max": [0.4, 0.2, 0.2] } } ] })",
                                 "ring.json");
    auto sim = buildSimulation(scene);
    sim->emitDue();
    auto& sp = std::get<Species<LinearElastic>>(sim->species()[0]);
    for (std::size_t i = 0; i < sp.size(); ++i) {
        sp.state.F[i](0, 0) = 1.02f;
        sp.p.x[i][0] *= 1.02;
    }
    const FrameStats start = sim->measure();
    ASSERT_GT(start.elasticEnergy, 0.0);
    double peakKinetic = 0.0, worstRise = 0.0;
    for (int n = 0; n < 200; ++n) {  // about two periods of the block's lowest longitudinal mode
        sim->substep(sim->settings().targetDt());
        const FrameStats st = sim->measure();
        peakKinetic = std::max(peakKinetic, st.kineticEnergy);
        worstRise = std::max(worstRise, st.totalEnergy() - start.totalEnergy());
        EXPECT_LT(st.momentum.norm(), 1e-6 * st.mass);
    }
    std::printf("released block: peak kinetic %.3g of the stored %.3g J, largest rise %.3g J\n", peakKinetic, start.elasticEnergy,
                worstRise);
    EXPECT_GT(peakKinetic, 0.2 * start.elasticEnergy);  // the block did ring
    EXPECT_LT(worstRise, 0.01 * start.elasticEnergy);   // and made no energy
}
