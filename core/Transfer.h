#pragma once
// APIC particle-to-grid and grid-to-particle transfers over the leaves of the sparse grid (thesis eq.
// 3.14-3.19, 3.24; Jiang et al. 2015), with the MLS-MPM fused force (Hu et al. 2018) as an option.
// P2G runs in two passes, one task per leaf in each: a particle leaf gathers its particles into a dense
// local block and writes the part in its own leaf, keeping the rest (the halo); then each grid leaf adds
// the halos that reach it. No two tasks write one node and every node sums in a fixed order: results are
// bit-identical whatever the number of threads.
#include <cstdint>
#include <limits>
#include <vector>

#include "core/Kernels.h"
#include "core/Species.h"
#include "sparse/SparseGrid.h"

namespace mpm {

enum class TransferScheme { APIC, PIC };
enum class ForceScheme { Standard, MLS };

struct TransferSettings {
    Interpolation interpolation = Interpolation::Quadratic;
    TransferScheme transfer = TransferScheme::APIC;
    ForceScheme force = ForceScheme::Standard;
};

/// What G2P learns while it passes over the particles.
struct G2PSummary {
    float maxSpeed = 0.0f;
    std::vector<float> minStiffnessKey;  ///< per species
    /// First particle (species, index in species) with a non-finite velocity or state, if any.
    int badSpecies = -1;
    int64_t badParticle = -1;
    const char* badField = nullptr;
};

/// Zeroes the grid, then scatters mass and momentum (with the stress impulse of a step dt) of all species.
void particlesToGrid(SparseGrid& grid, std::vector<AnySpecies>& species, const TransferSettings& s, float dt);

/// Gathers velocity and its affine part, updates deformation (with return mapping) and advects.
G2PSummary gridToParticles(const SparseGrid& grid, std::vector<AnySpecies>& species, const TransferSettings& s, float dt);

}  // namespace mpm
