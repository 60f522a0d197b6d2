// The viscous and yield-stress liquid cases (docs/validation/cases.md, cases 14 on): the `viscous` material
// (materials/HerschelBulkley.h) in flows with closed-form answers, set up as a user would (lattice sampling at the
// default particles per cell, the default shear modulus, released at rest or with the flow's own velocity).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>

#include "CaseSupport.h"

namespace mpm::validation::support {

namespace {

constexpr double kGravity = 9.81;

/// The `viscous` set's parameters, as the case scene gives them and a case edits them.
HerschelBulkley::Params& liquidOf(SceneDesc& d) { return std::get<HerschelBulkley::Params>(d.sets.at(0).params); }

/// The channel: a column 0.5 m tall falling between two sticky walls h = 0.1 m apart, two slip walls closing the
/// third axis (scenes/validation/viscous_channel.json). What a case reads of it after `frames` 40ths of a second:
/// the particles that started in the column's middle third (the ends' disturbance has not reached it), their
/// flow rate (the sum of their velocities along gravity) from their velocity and from their displacement over
/// the last two frames, and their mean drop since the start.
struct ChannelFlow {
    std::vector<std::pair<double, double>> middle;  ///< (x across the gap, v along gravity)
    double flowV = 0.0, flowX = 0.0, drop = 0.0, wall = 0.0;
};
constexpr double kGap = 0.1, kColumn = 0.5, kFrame = 1.0 / 40.0;

ChannelFlow channel(Simulation& sim, int frames) {
    auto& sp = only<HerschelBulkley>(sim);
    std::map<int32_t, double> yStart, yBefore;  // by id: the arrays are reordered as particles are binned
    for (std::size_t i = 0; i < sp.size(); ++i) yStart[sp.p.id[i]] = sp.p.x[i][1];
    ChannelFlow out;
    out.wall = runUntil(sim, (frames - 2) * kFrame);
    for (std::size_t i = 0; i < sp.size(); ++i) yBefore[sp.p.id[i]] = sp.p.x[i][1];
    out.wall += runUntil(sim, frames * kFrame);
    for (std::size_t i = 0; i < sp.size(); ++i) {
        const double y0 = yStart.at(sp.p.id[i]), y = sp.p.x[i][1], v = sp.p.v[i][1];
        if (y0 < kColumn / 3 || y0 > 2 * kColumn / 3) continue;
        out.middle.emplace_back(sp.p.x[i][0], v);
        out.flowV += v, out.flowX += (y - yBefore.at(sp.p.id[i])) / (2 * kFrame), out.drop += y0 - y;
    }
    out.drop /= double(out.middle.size());
    return out;
}

/// The largest difference, over tenths of the gap, between the particles' mean velocity along gravity and the
/// mean of u(x) over the same particles, with its sign (v - u: negative where the flow is faster downwards).
template <class U>
double worstTenth(const std::vector<std::pair<double, double>>& particles, U&& u) {
    constexpr int kBins = 10;
    double vSum[kBins] = {}, uSum[kBins] = {}, count[kBins] = {};
    for (const auto& [x, v] : particles) {
        const int b = std::clamp(int(x / kGap * kBins), 0, kBins - 1);
        vSum[b] += v, uSum[b] += u(x), ++count[b];
    }
    double worst = 0.0;
    for (int b = 0; b < kBins; ++b) {
        const double difference = count[b] > 0 ? (vSum[b] - uSum[b]) / count[b] : 1e9;
        if (std::abs(difference) > std::abs(worst)) worst = difference;
    }
    return worst;
}

// 14. Plane Poiseuille flow (viscosity mu = 50 Pa s, rho = 1400): the column settles in rho h^2 / (pi^2 mu) =
// 0.028 s to u(x) = rho g x (h - x) / (2 mu), at most u_max = rho g h^2 / (8 mu) = 0.343 m/s, where the walls' shear
// carries the weight. Measured at 0.25 s. The liquid holds tension: with the clamp the column's fast middle tears
// from its bottom end, which falls free, and the stretching carries weight along the column (docs/method.md).
CaseResult poiseuille(const CaseConfig& c, WallGhosts ghosts) {
    Setup s = load("viscous_channel", c, -1.0, [&](SceneDesc& d) { d.settings.wallGhosts = ghosts; });
    const HerschelBulkley::Params& m = liquidOf(s.scene);
    const double rho = m.density, mu = m.viscosity, uMax = rho * kGravity * kGap * kGap / (8.0 * mu);
    constexpr int kFrames = 10;
    const ChannelFlow f = channel(*s.sim, kFrames);
    // Signed along the flow: positive where the liquid runs faster than the parabola.
    const double faster = -worstTenth(f.middle, [&](double x) { return -rho * kGravity * x * (kGap - x) / (2.0 * mu); }) / uMax;
    const double worst = std::abs(faster);
    // Steady flow: the rate from the velocities and from the displacements must agree (1%).
    const double steady = std::abs(f.flowV / f.flowX - 1.0);
    return finish(*s.sim, f.wall, worst, worst < 0.02 && steady < 0.01,
                  kv({{"u_max", uMax}, {"worst_tenth_faster_by", faster}, {"flow_rate_velocity_vs_displacement", steady}}));
}

// 15. A Bingham plug (K = 20 Pa s, mirrored walls): the walls carry the column's weight with a shear stress
// tau_w = rho g h / 2 = 687 Pa. With tau_y = tau_w / 2 the liquid flows with a plug of half-width
// y_p = tau_y / (rho g) = h / 4 moving as one at u_p = rho g (h/2 - y_p)^2 / (2 K) = 0.215 m/s (at 0.5 s). With
// tau_y = 1.05 tau_w it hangs: released unstressed it sags elastically and rings about the static sag
// rho g h^2 / (12 G); its mean drop after 0.25 s must stay under twice the undamped ring's peak, 4 static sags.
CaseResult binghamPlug(const CaseConfig& c) {
    const auto withYield = [&](double share) {
        return load("viscous_channel", c, -1.0, [&](SceneDesc& d) {
            d.settings.wallGhosts = WallGhosts::Mirror;
            HerschelBulkley::Params& m = liquidOf(d);
            m.viscosity = 20.0f;
            m.yieldStress = float(share * m.density * kGravity * kGap / 2.0);
        });
    };
    Setup flows = withYield(0.5);
    const HerschelBulkley::Params& m = liquidOf(flows.scene);
    const double rho = m.density, K = m.viscosity, yp = m.yieldStress / (rho * kGravity);
    const double up = rho * kGravity * (kGap / 2 - yp) * (kGap / 2 - yp) / (2.0 * K);
    const ChannelFlow f = channel(*flows.sim, 20);
    double plugSum = 0.0, plugCount = 0.0, lo = 1e9, hi = -1e9;
    for (const auto& [x, v] : f.middle)
        if (std::abs(x - kGap / 2) < kGap / 10) plugSum += v, ++plugCount, lo = std::min(lo, v), hi = std::max(hi, v);
    const double plug = -plugSum / plugCount, error = std::abs(plug / up - 1.0), spread = (hi - lo) / up;

    Setup hangs = withYield(1.05);
    const double sag = rho * kGravity * kGap * kGap / (12.0 * liquidOf(hangs.scene).shearModulus);
    const ChannelFlow h = channel(*hangs.sim, 10);
    const double hangDrop = h.drop / sag;
    return finish(
        *flows.sim, f.wall + h.wall, error, error < 0.05 && spread < 0.01 && hangDrop < 4.0,
        kv({{"plug_speed", plug}, {"u_p", up}, {"plug_spread_over_u_p", spread}, {"hanging_drop_in_static_sags", hangDrop}}));
}

// 16. A decaying shear wave: v_x = A sin(k y), k = pi / H, between sticky walls H = 0.1 m apart (no gravity; free
// ends far from the middle third measured). The viscous liquid at flow index 1 is a Maxwell fluid of relaxation time
// lambda = K / G, whose mode decays as a(t) with lambda a'' + a' + nu k^2 a = 0: after the fast root (-1 / lambda)
// is gone, at the rate s = (1 - sqrt(1 - 4 lambda nu k^2)) / (2 lambda), nu k^2 (1 + lambda nu k^2 + ...)
// (1 / s = 28 ms here, lambda = 0.7 ms). Started in the mode (C = grad v, no stress), so only that mode rings.
CaseResult shearWave(const CaseConfig& c, WallGhosts ghosts) {
    Setup s = load("shear_wave", c, -1.0, [&](SceneDesc& d) { d.settings.wallGhosts = ghosts; });
    Simulation& sim = *s.sim;
    auto& sp = only<HerschelBulkley>(sim);
    const HerschelBulkley::Params& m = sp.params;
    constexpr double kH = 0.1, kLength = 0.6, kAmplitude = 0.1;
    const double k = M_PI / kH, lambda = double(m.viscosity) / m.shearModulus, nuk2 = m.viscosity / m.density * k * k;
    const double rate = (1.0 - std::sqrt(1.0 - 4.0 * lambda * nuk2)) / (2.0 * lambda);
    for (std::size_t i = 0; i < sp.size(); ++i) {
        const double y = sp.p.x[i][1];
        sp.p.v[i] = Vec3f(float(kAmplitude * std::sin(k * y)), 0.0f, 0.0f);
        sp.p.C[i] = Mat3f::Zero();
        sp.p.C[i](0, 1) = float(kAmplitude * k * std::cos(k * y));
    }
    sim.refreshSpeedBound();
    // The mode's amplitude in the middle third: the particles' v_x projected on sin(k y).
    const auto amplitude = [&] {
        double vs = 0.0, ss = 0.0;
        for (std::size_t i = 0; i < sp.size(); ++i) {
            if (std::abs(sp.p.x[i][0] - kLength / 2) > kLength / 6) continue;
            const double shape = std::sin(k * sp.p.x[i][1]);
            vs += sp.p.v[i][0] * shape, ss += shape * shape;
        }
        return vs / ss;
    };
    // ln a against t from a third of the decay time (the fast root gone 40 times over) to two decay times.
    constexpr int kSamples = 12;
    std::vector<double> t, lnA;
    double wall = 0.0;
    for (int n = 0; n <= kSamples; ++n) {
        const double at = (1.0 / 3.0 + n * (2.0 - 1.0 / 3.0) / kSamples) / rate;
        wall += runUntil(sim, at);
        t.push_back(at), lnA.push_back(std::log(amplitude()));
    }
    const double measured = -fitLine(t, lnA).first, error = std::abs(measured / rate - 1.0);
    // Signed against both rates: the Maxwell fluid's (the case's answer) and the Newtonian one 2.6% below it.
    return finish(sim, wall, error, error < 0.02,
                  kv({{"decay_rate", measured},
                      {"analytic", rate},
                      {"newtonian", nuk2},
                      {"vs_maxwell", measured / rate - 1.0},
                      {"vs_newtonian", measured / nuk2 - 1.0}}));
}

// 17. The slump test (Pashias et al. 1996, "A fifty cent rheometer for yield stress measurement", J. Rheol. 40): a
// cylinder of Bingham mud as tall as it is wide (H0 = 0.1 m, rho = 1600) released on a sticky floor slumps until
// its yield stress holds it. Pashias's model (Murata's, for a cylinder) lets the column yield where its axial stress
// reaches the yield stress in uniaxial compression, and gives the final height H = H0 Y (1 - ln Y) with
// Y = sigma_y / (rho g H0). Tresca's criterion puts sigma_y at 2 tau_y; this model's von Mises one (the equivalent
// shear stress |dev tau| / sqrt 2, materials/HerschelBulkley.h) at sqrt(3) tau_y, which the case compares with.
// K = 100 Pa s keeps the slump slow, as the test is run (the model is quasi-static: at K = 20 the column passed
// below its height within 0.4 s); two yield stresses, tau_y / (rho g H0) = 0.10 and 0.15. The height is the top of
// the particles within 2 cm of the axis at 3 s, plus the gap between the top and H0 at the start.
CaseResult mudSlump(const CaseConfig& c) {
    constexpr double kH0 = 0.1, kAxis = 0.02, kEnd = 3.0, kLast = 0.25;
    constexpr double kShares[2] = {0.10, 0.15};
    double height[2], pashias[2], tresca[2], worst = 0.0, wall = 0.0, creep = 0.0;
    std::vector<Setup> runs;
    for (int k = 0; k < 2; ++k) {
        const double share = kShares[k];
        runs.push_back(load("mud_slump", c, -1.0, [&](SceneDesc& d) {
            HerschelBulkley::Params& m = liquidOf(d);
            m.yieldStress = float(share * m.density * kGravity * kH0);
        }));
        Simulation& sim = *runs.back().sim;
        auto& sp = only<HerschelBulkley>(sim);
        const auto top = [&] {
            double y = -1e9;
            for (std::size_t i = 0; i < sp.size(); ++i)
                if (std::hypot(sp.p.x[i][0], sp.p.x[i][2]) < kAxis) y = std::max(y, sp.p.x[i][1]);
            return y;
        };
        const double offset = kH0 - top();
        wall += runUntil(sim, kEnd - kLast);
        const double before = top() + offset;
        wall += runUntil(sim, kEnd);
        height[k] = top() + offset;
        // H = H0 Y (1 - ln Y), Y the column's uniaxial yield stress over rho g H0: sqrt(3) tau_y (von Mises), 2 tau_y (Tresca).
        const auto pashiasHeight = [&](double y) { return kH0 * y * (1.0 - std::log(y)); };
        const double yieldShare = double(sp.params.yieldStress) / (sp.params.density * kGravity * kH0);
        pashias[k] = pashiasHeight(std::sqrt(3.0) * yieldShare);
        tresca[k] = pashiasHeight(2.0 * yieldShare);
        worst = std::max(worst, std::abs(height[k] / pashias[k] - 1.0));
        creep = std::max(creep, (before - height[k]) / kLast);
    }
    return finish(*runs.back().sim, wall, worst, worst < 0.1,
                  kv({{"height_010", height[0]},
                      {"pashias_010", pashias[0]},
                      {"tresca_010", tresca[0]},
                      {"height_015", height[1]},
                      {"pashias_015", pashias[1]},
                      {"tresca_015", tresca[1]},
                      {"top_creep_last_quarter_second", creep}}));
}

// 18. A Bingham layer stopping on an incline (the inclined-plane test of Coussot and Boyer 1995, Rheol. Acta 34;
// Liu and Mei 1989, Slow spreading of a sheet of Bingham fluid on an inclined plane, J. Fluid Mech. 207): a layer
// twice the critical thickness h_c = tau_y / (rho g sin theta) (0.1 m, theta = 20 degrees, K = 20 Pa s), 0.4 m
// long in a slab between slip planes, released on a sticky grid-aligned floor with gravity tilted. It runs
// downhill, thins and must stop where its basal shear stress rho g h (sin theta - cos theta dh/dx) (the long-wave
// balance) has fallen to tau_y. The thickness is measured from mass, not from the top: each cell-wide strip's
// particle volume V0 det F_E over its width and the slab's depth, fitted with a line over the middle third of the
// deposit. Error: the fit's middle thickness against h_c / (1 - cot theta dh/dx), the thickness at yield under the
// fitted slope; the layer must also have stopped (thinned by under 1% of h_c a second over the last half second).
CaseResult binghamIncline(const CaseConfig& c) {
    constexpr double kEnd = 5.0, kLast = 0.5;
    Setup s = load("bingham_incline", c);
    Simulation& sim = *s.sim;
    auto& sp = only<HerschelBulkley>(sim);
    const HerschelBulkley::Params& m = sp.params;
    const Vec3d g = s.scene.settings.gravity;
    const double theta = std::atan2(g[0], -g[1]), gravity = g.norm();
    const double hc = m.yieldStress / (m.density * gravity * std::sin(theta));
    const Box& layer = std::get<Box>(s.scene.sets.at(0).shape);
    const double depth = layer.max[2] - layer.min[2], strip = sim.settings().dx;
    // Thickness of each strip along x, from the particles' current volumes.
    const auto profile = [&] {
        std::map<long, double> volume;
        for (std::size_t i = 0; i < sp.size(); ++i)
            volume[long(std::floor(sp.p.x[i][0] / strip))] += sp.p.volume0[i] * float(sp.state.Fe[i].determinant());
        std::vector<double> x, h;
        for (const auto& [b, v] : volume) x.push_back((double(b) + 0.5) * strip), h.push_back(v / (strip * depth));
        return std::pair{x, h};
    };
    // The middle third of the deposit (strips at least a quarter of h_c thick, the spray and toe left out): the
    // fitted line's thickness at the deposit's centre, its slope, and the deposit's ends.
    struct Deposit {
        double thickness, slope, tail, front;
    };
    const auto middle = [&] {
        auto [x, h] = profile();
        double lo = 1e30, hi = -1e30;
        for (std::size_t k = 0; k < x.size(); ++k)
            if (h[k] > 0.25 * hc) lo = std::min(lo, x[k]), hi = std::max(hi, x[k]);
        std::vector<double> xm, hm;
        for (std::size_t k = 0; k < x.size(); ++k)
            if (x[k] > lo + (hi - lo) / 3 && x[k] < hi - (hi - lo) / 3) xm.push_back(x[k]), hm.push_back(h[k]);
        const auto [slope, intercept] = fitLine(xm, hm);
        const double centre = 0.5 * (lo + hi);
        return Deposit{slope * centre + intercept, slope, lo, hi};
    };
    double wall = runUntil(sim, kEnd - kLast);
    const double before = middle().thickness;
    wall += runUntil(sim, kEnd);
    const auto [h, slope, tail, front] = middle();
    const double atYield = hc / (1.0 - slope / std::tan(theta)), error = std::abs(h / atYield - 1.0);
    const double thinning = (before - h) / kLast;
    constexpr double kStoppedShare = 0.01;  // of h_c a second
    return finish(sim, wall, error, error < 0.05 && std::abs(thinning) < kStoppedShare * hc,
                  kv({{"thickness", h},
                      {"h_c", hc},
                      {"thickness_over_h_c", h / hc},
                      {"surface_slope", slope},
                      {"at_yield", atYield},
                      {"deposit_length", front - tail},
                      {"thinning_per_second", thinning}}));
}

}  // namespace

void addViscousCases(std::vector<ValidationCase>& v) {
    for (const auto& [suffix, ghosts] : {std::pair{"", WallGhosts::Held}, std::pair{"_mirror", WallGhosts::Mirror}}) {
        const WallGhosts g = ghosts;
        v.push_back({std::string("poiseuille") + suffix,
                     "worst tenth of the gap: |mean v - mean u(x)| / u_max at 0.25 s (u_max = 0.343 m/s)",
                     "< 2% at h/dx >= 10, flow rate from velocity and from displacement within 1%", 0, 1, 0,
                     [g](const CaseConfig& c) { return poiseuille(c, g); }});
    }
    v.push_back({"bingham_plug", "|plug speed / u_p - 1| (u_p = 0.215 m/s, tau_y = tau_w / 2)",
                 "< 5%, plug rigid to 1% of u_p, hangs at tau_y = 1.05 tau_w", 0, 1, 0, binghamPlug});
    for (const auto& [suffix, ghosts] : {std::pair{"", WallGhosts::Held}, std::pair{"_mirror", WallGhosts::Mirror}}) {
        const WallGhosts g = ghosts;
        v.push_back({std::string("shear_wave") + suffix, "|decay rate / Maxwell fluid's - 1|", "< 2% at H/dx >= 10", 0, 1, 0,
                     [g](const CaseConfig& c) { return shearWave(c, g); }});
    }
    v.push_back({"mud_slump", "|height at 3 s / Pashias's - 1| (von Mises form), worse of tau_y / (rho g H0) = 0.10, 0.15",
                 "< 10% at H0/dx >= 10", 0, 1, 0, mudSlump});
    v.push_back({"bingham_incline", "|deposit thickness / the long-wave thickness at yield - 1|, middle third at 5 s",
                 "< 5% at h_c/dx >= 10, and stopped (thinning under 1% of h_c a second)", 0, 1, 0, binghamIncline});
}

}  // namespace mpm::validation::support
