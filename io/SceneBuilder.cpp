#include "io/SceneBuilder.h"

#include "core/Colliders.h"
#include "io/Sampling.h"

namespace mpm {

SpeciesLayout speciesLayout(const SceneDesc& scene) {
    SpeciesLayout out;
    for (std::size_t i = 0; i < scene.sets.size(); ++i) {
        out.speciesOfSet.push_back(int(i));
        out.setOfSpecies.push_back(int(i));
        out.materialOfSpecies.push_back(materialIndex(scene.sets[i].params));
        out.setNames.push_back(scene.sets[i].name);
    }
    return out;
}

std::unique_ptr<Simulation> buildSimulation(const SceneDesc& scene) {
    auto sim = std::make_unique<Simulation>(scene.settings);
    const SpeciesLayout layout = speciesLayout(scene);
    for (std::size_t i = 0; i < scene.sets.size(); ++i) {
        const ParticleSetDesc& d = scene.sets[i];
        AnyMaterialParams params = d.params;
        visitMaterialParams(params, [&]<class M>(typename M::Params& p) { M::scaleStiffness(p, d.lambdaScale, d.muScale); });
        const int species = sim->addSpecies(makeSpecies(d.name, params));
        if (species != layout.speciesOfSet[i])
            throw std::logic_error("buildSimulation: species order differs from speciesLayout");
        Emitter e;
        e.species = species;
        e.set = uint16_t(i);
        e.positions = sampleShape(d.shape, scene.settings.dx, d.particlesPerCell, d.count, d.sampling, d.seed);
        if (e.positions.empty())
            throw SceneError(scene.file + ": /sets/" + std::to_string(i) +
                             "/shape: no particle fits in the shape at dx = " + std::to_string(scene.settings.dx));
        e.velocity = d.velocity;
        e.volume = float(shapeVolume(d.shape) / double(e.positions.size()));
        const float density = std::visit([](const auto& p) { return p.density; }, params);
        e.mass = float(e.volume * density * d.massScale);
        e.startFrame = d.startFrame;
        e.durationFrames = d.durationFrames;
        e.pauseFrames = d.pauseFrames;
        sim->addEmitter(std::move(e));
    }
    for (const ColliderDesc& c : scene.colliders) sim->addCollider(makeCollider(c.shape, c.boundary, c.friction));
    return sim;
}

}  // namespace mpm
