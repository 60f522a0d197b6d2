#pragma once
// APIC particle-to-grid and grid-to-particle transfers over the leaves of the sparse grid (thesis eq.
// 3.14-3.19, 3.24; Jiang et al. 2015), with the MLS-MPM fused force (Hu et al. 2018) as an option.
// P2G runs in two passes, one task per leaf in each: a particle leaf gathers its particles into a dense
// local block and writes the part in its own leaf, keeping the rest (the halo); then each grid leaf adds
// the halos that reach it. No two tasks write one node and every node sums in a fixed order: results are
// bit-identical whatever the number of threads.
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "core/Kernels.h"
#include "core/Settings.h"
#include "core/Species.h"
#include "sparse/SparseGrid.h"

namespace mpm {

/// What G2P learns while it passes over the particles.
struct G2PSummary {
    float maxSpeed = 0.0f;
    std::vector<float> minStiffnessKey;  ///< per species
    /// First particle (species, index in species) with a non-finite velocity or state, if any.
    int badSpecies = -1;
    int64_t badParticle = -1;
    int32_t badId = -1;  ///< its id (on several ranks: of the particle one process would report)
    const char* badField = nullptr;
};

/// P2G halo parts that cross ranks (docs/distributed.md): a part is the nodes of one particle leaf's block
/// that lie in its neighbour d (1..7), the leaf at the particle leaf's coordinate + d.
struct HaloParts {
    struct Part {
        Vec3i leaf;           ///< leaf coordinate of the leaf receiving the part
        int32_t d;            ///< which neighbour of its particle leaf that leaf is
        int8_t lo[3], hi[3];  ///< the part's box in the particle leaf's block coordinates
        uint64_t offset;      ///< where its nodes start in data, in nodes (4 floats: mass, momentum)
    };
    std::vector<Part> parts;
    std::vector<float> data;
};
/// How P2G meets other ranks: `owned` marks the leaves this rank sums (the others are ghosts); `exchange`
/// takes the parts for ghost leaves and returns the parts others computed for owned leaves. Each owned leaf
/// then adds its parts d = 1..7 in the same order as one process, whichever rank computed them.
struct RemoteHalos {
    const std::vector<uint8_t>* owned = nullptr;
    std::function<HaloParts(HaloParts&&)> exchange;
};

/// Zeroes the grid, then scatters mass and momentum (with the stress impulse of a step dt) of all species.
void particlesToGrid(SparseGrid& grid, std::vector<AnySpecies>& species, const TransferSettings& s, float dt,
                     const RemoteHalos* remote = nullptr);

/// Gathers velocity and its affine part, updates deformation (with return mapping) and advects.
G2PSummary gridToParticles(const SparseGrid& grid, std::vector<AnySpecies>& species, const TransferSettings& s, float dt);

}  // namespace mpm
