// libFuzzer target on the scene reader and builder: any bytes go through parseScene and the budget estimate, and a
// scene the budget finds small is built (its sets sampled, its colliders' distance fields made from the meshes and
// VDB files beside it, the engine set up) and takes one substep. A scene that is not usable must end in SceneError;
// a stability check that fires in the substep (SimulationError) is a legal end for wild parameters; anything else
// (a crash, a hang past -timeout, memory past -rss_limit_mb, a sanitizer report, another exception) is a finding.
// Built and run by tools/fuzz.sh with clang's -fsanitize=fuzzer,address,undefined; MPM_FUZZ_ASSETS is the folder
// the scenes' files are looked for in (scenes/assets: the example meshes and the rock's level set).
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/Simulation.h"
#include "core/Stability.h"
#include "io/SceneBudget.h"
#include "io/SceneBuilder.h"
#include "io/SceneReader.h"

namespace {
/// Scenes built and stepped: small enough that a build takes well under the per-input limit under the sanitizers,
/// so that one that does not is a finding (an estimate that missed a cost), and the fuzzer keeps its pace.
constexpr double kBuildUpToParticles = 4000.0;
constexpr double kBuildUpToBytes = 256.0 * (1 << 20);
/// The distance fields of the mesh sets (estimated from the meshes before the budget builds them) and of the
/// colliders: a scene with more is not built, because OpenVDB makes them in Release code here too, at its own
/// pace. A torus set scaled to 5.5 m at dx 0.05 (a 260 MB field) took 55 s; the rock's level set grown to dx 1.04's
/// band (59 MB, 12e6 voxels) 10 s. The seed corpus' fields take up to 15 MB.
constexpr double kBuildUpToFieldBytes = 16.0 * (1 << 20);
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    try {
        const mpm::SceneDesc scene = mpm::parseScene(text, MPM_FUZZ_ASSETS "/fuzz.json");
        double setFields = 0.0;
        for (std::size_t i = 0; i < scene.sets.size(); ++i) setFields += mpm::setFieldBytes(mpm::SetEntry(scene, i));
        if (!(setFields <= kBuildUpToFieldBytes)) return 0;
        const mpm::SceneBudget budget = mpm::estimateBudget(scene, false);
        if (!budget.problems.empty() || !(budget.peakParticles <= kBuildUpToParticles) ||
            !(budget.memoryBytes <= kBuildUpToBytes) || !(budget.colliderBytes <= kBuildUpToFieldBytes))
            return 0;
        const auto sim = mpm::buildSimulation(scene);
        sim->emitDue();
        sim->substep(scene.settings.targetDt());
    } catch (const mpm::SceneError&) {
    } catch (const mpm::SimulationError&) {}
    return 0;
}
