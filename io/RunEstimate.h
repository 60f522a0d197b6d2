#pragma once
// How long a run will take here: its work (SceneBudget's substeps and particle-substeps) at costs measured on this
// machine, now, by simulating and writing two small blocks of water with the scene's own output settings. A
// substep costs a fixed part (binning, colliders, the threads' hand-overs) and a part per particle; so does a
// frame's writing (the surface's meshing most). Both are fitted from the two blocks.
#include "io/SceneBudget.h"
#include "io/SceneDesc.h"

namespace mpm {

/// Fills budget.runSeconds and budget.runBasis; takes about a second, on the threads of the current arena.
void estimateRunTime(const SceneDesc& scene, SceneBudget& budget);

}  // namespace mpm
