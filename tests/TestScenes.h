#pragma once
// Small scene builders shared by the tests.
#include <vector>

#include "core/Colliders.h"
#include "core/Simulation.h"

namespace mpm::test {

/// Lattice points with the given spacing filling the box [lo, hi), offset by half a spacing.
inline std::vector<Vec3d> lattice(const Vec3d& lo, const Vec3d& hi, double spacing) {
    std::vector<Vec3d> pts;
    for (double x = lo[0] + 0.5 * spacing; x < hi[0]; x += spacing)
        for (double y = lo[1] + 0.5 * spacing; y < hi[1]; y += spacing)
            for (double z = lo[2] + 0.5 * spacing; z < hi[2]; z += spacing) pts.emplace_back(x, y, z);
    return pts;
}

/// Adds a water species and a block of it at 8 particles per cell with density rho.
inline int addWaterBlock(Simulation& sim, const Vec3d& lo, const Vec3d& hi, const Vec3f& v = Vec3f::Zero(),
                         Water::Params params = {}) {
    Species<Water> s;
    s.name = "water";
    s.params = params;
    const int id = sim.addSpecies(std::move(s));
    const double spacing = 0.5 * sim.settings().dx;
    const double vol = spacing * spacing * spacing;
    sim.addParticles(id, lattice(lo, hi, spacing), v, float(vol * params.density), float(vol), 0);
    return id;
}

}  // namespace mpm::test
