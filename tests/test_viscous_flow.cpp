// The viscous liquid (materials/HerschelBulkley.h) in flows with analytic answers, run as a user sets them up
// (lattice sampling at the default 8 particles a cell, the default shear modulus, released at rest): plane
// Poiseuille flow between two sticky walls, and a Bingham liquid hanging or flowing as a plug between them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "io/SceneBuilder.h"
#include "io/SceneReader.h"
#include "tests/SceneVariants.h"

using namespace mpm;
using mpm::test::RigidMap;
using mpm::test::transformScene;
using nlohmann::json;

namespace {

/// Every particle's position and velocity, mapped back into the original scene's axes.
struct Particle {
    Vec3d x, v;
    int32_t id;
};
std::vector<Particle> particlesBack(const Simulation& sim, const RigidMap& m) {
    std::vector<Particle> out;
    for (const AnySpecies& s : sim.species()) {
        const ParticleArrays& P = particlesOf(s);
        for (std::size_t i = 0; i < P.size(); ++i)
            out.push_back({m.pointBack(P.x[i]), m.vectorBack(P.v[i].cast<double>()), P.id[i]});
    }
    return out;
}

/// A column of liquid 0.5 m tall falling between two sticky walls h = 0.1 m apart (dx 0.01), two slip walls 4 cells
/// apart closing the third axis, after `frames` 40ths of a second: the particles that started in its middle third,
/// their flow rate (the sum of their velocities along gravity) from their velocity and from their displacement
/// over the last two frames, and their mean displacement along gravity since the start. The liquid holds tension
/// (`tension`): clamped to no tension, the column's fast middle tears from its bottom end, which falls free, and the
/// column's stretching then carries 1-3% of its weight along its length (measured: the stress gradient across the
/// gap 1.2% under rho g), which the walls' solution leaves out.
struct ChannelFlow {
    std::vector<Particle> middle;
    double flowV = 0.0, flowX = 0.0, drop = 0.0;
};
ChannelFlow fallBetweenStickyWalls(const json& materialParams, const char* ghosts, int frames, const RigidMap& placement = {}) {
    constexpr double kColumn = 0.5;
    json scene = json::parse(R"({"simulation": {"frames": 10, "fps": 40, "dx": 0.01}, "output": {"surface": false},
        "sets": [{"material": "viscous", "sampling": "lattice", "shape": {"type": "box", "min": [0, 0, 0], "max": [0.1, 0.5, 0.04]}}],
        "colliders": [{"type": "plane", "point": [0, 0, 0], "normal": [1, 0, 0], "boundary": "sticky"},
                      {"type": "plane", "point": [0.1, 0, 0], "normal": [-1, 0, 0], "boundary": "sticky"},
                      {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "boundary": "slip"},
                      {"type": "plane", "point": [0, 0, 0.04], "normal": [0, 0, -1], "boundary": "slip"}]})");
    scene["simulation"]["wall_ghosts"] = ghosts;
    scene["sets"][0]["material_params"] = materialParams;
    scene["sets"][0]["material_params"]["tension"] = true;
    const RigidMap& asWritten = placement;
    auto sim = buildSimulation(parseScene(transformScene(scene, placement).dump(), "channel.json"));
    sim->emitDue();
    std::map<int32_t, double> yStart;
    for (const Particle& p : particlesBack(*sim, asWritten)) yStart[p.id] = p.x[1];
    while (sim->state().frame < frames - 2) sim->advanceFrame();
    std::map<int32_t, double> yBefore;  // by id: the arrays are reordered as particles are binned
    for (const Particle& p : particlesBack(*sim, asWritten)) yBefore[p.id] = p.x[1];
    const double t0 = sim->time();
    while (sim->state().frame < frames) sim->advanceFrame();
    const std::vector<Particle> after = particlesBack(*sim, asWritten);
    const double span = sim->time() - t0;
    ChannelFlow out;
    for (const Particle& p : after) {
        const double y0 = yStart.at(p.id);
        if (y0 < kColumn / 3 || y0 > 2 * kColumn / 3) continue;
        out.middle.push_back(p);
        out.flowV += p.v[1], out.flowX += (p.x[1] - yBefore.at(p.id)) / span, out.drop += yStart.at(p.id) - p.x[1];
    }
    out.drop /= double(out.middle.size());
    return out;
}

/// The largest difference, over tenths of the gap, between the particles' mean velocity along gravity and the
/// mean of u(x) over the same particles.
template <class U>
double worstTenth(const std::vector<Particle>& particles, double h, U&& u) {
    constexpr int kBins = 10;
    double vSum[kBins] = {}, uSum[kBins] = {}, count[kBins] = {};
    for (const Particle& p : particles) {
        const int b = std::clamp(int(p.x[0] / h * kBins), 0, kBins - 1);
        vSum[b] += p.v[1], uSum[b] += u(p.x[0]), ++count[b];
    }
    double worst = 0.0;
    for (int b = 0; b < kBins; ++b) worst = std::max(worst, count[b] > 0 ? std::abs(vSum[b] - uSum[b]) / count[b] : 1e9);
    return worst;
}

}  // namespace

TEST(ViscousFlow, PlanePoiseuilleFlowBetweenStickyWallsHasTheParabolicProfile) {
    // A column of viscous liquid (rho 1400, mu 50 Pa s) 0.5 m tall falls between two sticky walls h = 0.1 m apart
    // (10 cells at dx 0.01), two frictionless slip walls 4 cells apart closing the third axis. It settles in
    // rho h^2 / (pi^2 mu) = 0.028 s to u(x) = rho g x (h - x) / (2 mu), at most 0.343 m/s, where the walls' shear
    // carries the weight. Measured at 0.25 s in the middle third of the column (the ends' disturbance has spread
    // sqrt(nu t) = 0.1 m): each tenth of the gap's mean velocity against the parabola's mean over the same
    // particles (band: 2% of u_max), and the flow rate from the particles' velocity against their displacement over
    // the last 0.05 s (band 1%: the flow is steady, so the two must agree).
    // Measured, as the worst tenth: 0.9% with mirrored wall ghosts (the quadratic B-spline smooths the parabola by
    // (dx / h)^2 = 1%), 3.8% with held ones (faster: the held row carries the wall's shear, and the first free row
    // misses the wall's traction), allowed 5%. Not run, because they fail (docs/method.md, section 7): walls off the
    // grid's rows. Moved 0.37 cells along their normal, a sticky wall holds the row behind it or the row in front,
    // which moves the no-slip line by up to half a cell: 24% of u_max at 10 cells across; turned about an oblique
    // axis and moved, 17%.
    const double h = 0.1, rho = 1400.0, mu = 50.0, g = 9.81, uMax = rho * g * h * h / (8.0 * mu);
    for (const auto& [ghosts, band] : {std::pair{"mirror", 0.02}, std::pair{"held", 0.05}}) {
        const ChannelFlow f = fallBetweenStickyWalls(json{{"viscosity", mu}}, ghosts, 10);
        const double worst = worstTenth(f.middle, h, [&](double x) { return -rho * g * x * (h - x) / (2.0 * mu); });
        EXPECT_LT(worst / uMax, band) << ghosts;
        EXPECT_NEAR(f.flowV, f.flowX, 0.01 * std::abs(f.flowX)) << ghosts;
    }
}

TEST(ViscousFlow, ABinghamColumnBetweenStickyWallsHangsAboveItsYieldStressAndFlowsAsAPlugBelow) {
    // The same column as a Bingham liquid (K 20 Pa s, mirrored walls): the walls must carry its weight, a shear
    // stress of rho g h / 2 = 687 Pa. With a yield stress 5% above that it hangs: released unstressed, it sags
    // elastically and rings about the static sag rho g h^2 / (12 G) = 0.16 mm (the mean over the gap), so its mean
    // drop after 0.25 s must stay under twice the undamped ring's peak, 4 static sags (measured: 2.6).
    // With half of it as its yield stress it flows, with a plug of half-width y_p = tau_y / (rho g) = h / 4 in the
    // middle moving as one, at u_p = rho g (h/2 - y_p)^2 / (2 K) = 0.215 m/s (measured at 0.5 s: it settles more slowly
    // than the Newtonian column, 0.7 of the gap closed every 0.025 s). Bands: the middle fifth within 1% of u_p of its
    // own mean (rigid), and that mean within 5% of u_p (measured 3.8% slow). The yielded layers are further off (11%
    // of u_p in the worst tenth): the plug, an elastic solid in this model, keeps axial stress from its release and
    // sits on the yield surface with its shear stress under the yield stress (tau_eq 341 Pa of 343, tau_xy 89-222 Pa),
    // so the layers take more of the shear than a rigid-plastic Bingham liquid's (docs/method.md, section 4).
    const double h = 0.1, rho = 1400.0, g = 9.81, K = 20.0, wallStress = rho * g * h / 2.0;
    const HerschelBulkley::Params defaults;
    const double staticSag = rho * g * h * h / (12.0 * defaults.shearModulus);
    const ChannelFlow hangs = fallBetweenStickyWalls(json{{"viscosity", K}, {"yield_stress", 1.05 * wallStress}}, "mirror", 10);
    EXPECT_LT(std::abs(hangs.drop), 4.0 * staticSag);

    const double tauY = 0.5 * wallStress, yp = tauY / (rho * g), up = rho * g * (h / 2 - yp) * (h / 2 - yp) / (2.0 * K);
    const ChannelFlow flows = fallBetweenStickyWalls(json{{"viscosity", K}, {"yield_stress", tauY}}, "mirror", 20);
    double plugSum = 0.0, plugCount = 0.0, lo = 1e9, hi = -1e9;
    for (const Particle& p : flows.middle)
        if (std::abs(p.x[0] - h / 2) < h / 10)
            plugSum += p.v[1], ++plugCount, lo = std::min(lo, p.v[1]), hi = std::max(hi, p.v[1]);
    const double plug = -plugSum / plugCount;
    EXPECT_LT(hi - lo, 0.01 * up);
    EXPECT_NEAR(plug, up, 0.05 * up);
    EXPECT_NEAR(flows.flowV, flows.flowX, 0.01 * std::abs(flows.flowX));
}

TEST(ViscousFlow, ALiquidThatWouldActAsASolidIsWarnedOf) {
    // Relaxation time K / G against a frame: honey's 1.4e-4 s is silent; 1e6 Pa s over the default G (14 s) and lava's
    // 1e3 over a G lowered by mu_scale to 1e4 Pa (0.1 s, over 24 fps's 0.042 s) are warned of, naming the key.
    const auto warningsOf = [](const std::string& params, double muScale) {
        json scene = json::parse(R"({"simulation": {"frames": 2, "fps": 24}, "sets": [{"material": "viscous",
            "shape": {"type": "sphere", "center": [0, 0.2, 0], "radius": 0.05}}]})");
        scene["sets"][0]["material_params"] = json::parse(params);
        scene["sets"][0]["mu_scale"] = muScale;
        std::string all;
        for (const std::string& w : sceneWarnings(parseScene(scene.dump(), "liquid.json"))) all += w + "\n";
        return all;
    };
    EXPECT_EQ(warningsOf("{}", 1.0).find("relaxes in"), std::string::npos);
    const std::string stiff = warningsOf(R"({"viscosity": 1e6})", 1.0);
    EXPECT_NE(stiff.find("liquid.json: /sets/0/material_params/viscosity: 1e+06 over the shear modulus 70000 Pa relaxes in"),
              std::string::npos)
        << stiff;
    EXPECT_NE(warningsOf(R"({"viscosity": 1e3})", 1.0 / 7.0).find("relaxes in 0.1 s"), std::string::npos);
}
