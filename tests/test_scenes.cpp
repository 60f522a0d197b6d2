// Scene checks (issue 4): how whole scenes of the solid materials behave, which the per-material tests
// cannot see. Each scene is scene-file text read by the real parser, as a user's file would be.
#include <gtest/gtest.h>

#include <algorithm>

#include "io/Scene.h"

using namespace mpm;

namespace {

std::unique_ptr<Simulation> build(const std::string& text, SceneDesc& scene) {
    scene = parseScene(text, "<test scene>");
    return buildSimulation(scene);
}

}  // namespace

TEST(SceneChecks, WaterPouredOnJellyDeformsItAndIsPushedBack) {
    const std::string text = R"({
      "simulation": { "frames": 12, "fps": 24, "substeps": 10, "dx": 0.02, "gravity": [0, -9.81, 0] },
      "sets": [
        { "name": "jelly", "material": "jelly", "material_params": { "youngs_modulus": 2e4, "density": 1000 },
          "shape": { "type": "box", "min": [-0.16, 0.0, -0.16], "max": [0.16, 0.12, 0.16] } },
        { "name": "water", "material": "water",
          "shape": { "type": "box", "min": [-0.08, 0.2, -0.08], "max": [0.08, 0.36, 0.08] } } ],
      "colliders": [ { "type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "boundary": "sticky" } ] })";
    SceneDesc scene;
    auto sim = build(text, scene);
    sim->emitDue();
    const ParticleArrays& jelly = particlesOf(sim->species()[0]);
    const ParticleArrays& water = particlesOf(sim->species()[1]);
    auto topOfJellyCentre = [&] {  // the highest jelly particle within the water's footprint
        double top = 0.0;
        for (const Vec3d& x : jelly.x)
            if (std::abs(x[0]) < 0.06 && std::abs(x[2]) < 0.06) top = std::max(top, x[1]);
        return top;
    };
    const double restTop = topOfJellyCentre();
    double lowestTop = restTop, lowestWater = 1.0, waterVyAfterLowest = -1.0;
    for (int f = 0; f < scene.frames; ++f) {
        sim->advanceFrame();
        lowestTop = std::min(lowestTop, topOfJellyCentre());
        // Water that runs off the sides falls to the floor; only the water above the jelly's inner footprint
        // is held by the jelly: it must not sink in, and it is what the jelly pushes back.
        double minY = 1.0, vy = 0.0;
        int over = 0;
        for (std::size_t i = 0; i < water.size(); ++i)
            if (std::abs(water.x[i][0]) < 0.12 && std::abs(water.x[i][2]) < 0.12) {
                minY = std::min(minY, water.x[i][1]);
                vy += water.v[i][1];
                ++over;
            }
        if (minY < lowestWater) lowestWater = minY;
        else if (over > 0) waterVyAfterLowest = std::max(waterVyAfterLowest, vy / over);
    }
    // The water lands (the jelly top sits at 0.12) and dents the jelly by more than a cell's worth of strain.
    EXPECT_LT(lowestTop, restTop - 0.01) << "the jelly should give under the water";
    // The jelly holds the water up: over the jelly no water sinks more than a cell below the dented top,
    // and after the water's lowest point the mean vertical velocity of the water over the jelly turns
    // upward (measured +0.11 m/s; the top dips from 0.120 to 0.103 m and rebounds to 0.119).
    EXPECT_GT(lowestWater, lowestTop - 0.02) << "water sank more than a cell into the jelly";
    EXPECT_GT(waterVyAfterLowest, 0.0) << "the jelly did not push the water back";
}
