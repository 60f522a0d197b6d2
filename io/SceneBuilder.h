#pragma once
// From a scene description to a ready-to-run Simulation: one species per particle set (its material with
// the set's Lame scales), the set sampled in its shape as an emitter, and the colliders.
#include <memory>
#include <string>
#include <vector>

#include "io/SceneDesc.h"

namespace mpm {

/// Which species each set became and what each species is, for the writers. The builder makes species s
/// from set s; this says so explicitly instead of every reader of the output assuming it.
struct SpeciesLayout {
    std::vector<int> speciesOfSet;
    std::vector<int> setOfSpecies;
    std::vector<int> materialOfSpecies;  ///< index into materialSceneNames()
    std::vector<std::string> setNames;   ///< by set index
};

SpeciesLayout speciesLayout(const SceneDesc& scene);

/// Builds the simulation the scene describes. Throws SceneError when a set's shape holds no particle.
std::unique_ptr<Simulation> buildSimulation(const SceneDesc& scene);

}  // namespace mpm
