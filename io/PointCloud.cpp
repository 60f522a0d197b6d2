#include "io/PointCloud.h"

namespace mpm {

PointCloud gatherPoints(const std::vector<AnySpecies>& species, const std::vector<int>& materialOfSpecies) {
    PointCloud f;
    std::size_t n = 0;
    for (const AnySpecies& s : species) n += particlesOf(s).size();
    f.x.reserve(n);
    f.v.reserve(n);
    f.id.reserve(n);
    f.material.reserve(n);
    f.set.reserve(n);
    for (std::size_t s = 0; s < species.size(); ++s) {
        const ParticleArrays& P = particlesOf(species[s]);
        f.x.insert(f.x.end(), P.x.begin(), P.x.end());
        f.v.insert(f.v.end(), P.v.begin(), P.v.end());
        f.id.insert(f.id.end(), P.id.begin(), P.id.end());
        f.material.insert(f.material.end(), P.size(), s < materialOfSpecies.size() ? materialOfSpecies[s] : 0);
        f.set.insert(f.set.end(), P.set.begin(), P.set.end());
        f.speciesStart.push_back(f.x.size());
    }
    return f;
}

PointCloud PointCloud::subset(const std::vector<int>& species) const {
    PointCloud out;
    for (int s : species) {
        const std::size_t a = speciesStart[s], b = speciesStart[s + 1];
        out.x.insert(out.x.end(), x.begin() + a, x.begin() + b);
        out.v.insert(out.v.end(), v.begin() + a, v.begin() + b);
        out.id.insert(out.id.end(), id.begin() + a, id.begin() + b);
        out.material.insert(out.material.end(), material.begin() + a, material.begin() + b);
        out.set.insert(out.set.end(), set.begin() + a, set.begin() + b);
        out.speciesStart.push_back(out.x.size());
    }
    return out;
}

}  // namespace mpm
