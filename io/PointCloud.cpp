#include "io/PointCloud.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace mpm {

PointAttributes PointAttributes::of(const std::vector<std::string>& requested) {
    PointAttributes a;
    for (const std::string& r : requested) {
        if (r == "J")
            a.J = true;
        else if (r == "Jp")
            a.Jp = true;
        else if (r == "stress_norm")
            a.stressNorm = true;
        else if (r == "F")
            a.F = true;
        else if (r == "plastic_strain")
            a.plasticStrain = true;
        else if (std::find(parameterNames().begin(), parameterNames().end(), r) != parameterNames().end())
            a.parameters.push_back(r);
        else
            throw std::invalid_argument("unknown point attribute \"" + r + "\"");
    }
    return a;
}

namespace {

/// The material parameters PointAttributes::parameterNames lists, in its order; density is read from the particle.
enum class Parameter { Density, YoungsModulus, PoissonRatio, BulkModulus, Viscosity, YieldStress };

Parameter parameterNamed(const std::string& name) {
    const auto& names = PointAttributes::parameterNames();
    return Parameter(std::find(names.begin(), names.end(), name) - names.begin());
}

/// Parameter `which` (not density) of a parameter set, in SI units, read from what the model keeps: Young's
/// modulus and Poisson's ratio back from mu and lambda (E = mu (3 lambda + 2 mu) / (lambda + mu),
/// nu = lambda / (2 (lambda + mu))), and 0 where the model has no such parameter.
template <class Params>
float parameterValue(const Params& m, Parameter which) {
    constexpr bool kLame = requires { m.mu + m.lambda; };
    if constexpr (kLame) {
        const double mu = m.mu, lambda = m.lambda;
        if (which == Parameter::YoungsModulus) return float(mu * (3.0 * lambda + 2.0 * mu) / (lambda + mu));
        if (which == Parameter::PoissonRatio) return float(lambda / (2.0 * (lambda + mu)));
        if (which == Parameter::BulkModulus) return float(lambda + 2.0 * mu / 3.0);
    }
    if constexpr (requires { m.bulkModulus; })
        if (which == Parameter::BulkModulus) return m.bulkModulus;
    if constexpr (requires { m.viscosity; })
        if (which == Parameter::Viscosity) return m.viscosity;
    if constexpr (requires { m.yieldStress; })
        if (which == Parameter::YieldStress) return m.yieldStress;
    return 0.0f;
}

/// Appends the per-particle quantities of one species that the attributes ask for, through the model's own
/// functions (materials/Materials.h): tau / J for the stress, and F and Jp where the model keeps them.
template <class Sp>
void appendMaterialAttributes(const Sp& sp, const PointAttributes& a, PointCloud& f) {
    using M = typename Sp::Material;
    const std::size_t n = sp.p.size();
    for (std::size_t i = 0; i < n; ++i) {
        const float J = M::volumeRatio(sp.state, i);
        f.pscale.push_back(0.5f * std::cbrt(sp.p.volume0[i] * J));
        if (a.J) f.J.push_back(J);
        if (a.stressNorm) f.stressNorm.push_back(M::kirchhoff(sp.paramsOf(i), sp.state, i).norm() / J);
        if (a.F) {
            if constexpr (requires { M::deformationGradient(sp.state, i); })
                f.F.push_back(M::deformationGradient(sp.state, i));
            else
                f.F.push_back(std::cbrt(J) * Mat3f::Identity());
        }
        if (a.Jp) {
            if constexpr (requires { M::plasticVolumeRatio(sp.state, i); })
                f.Jp.push_back(M::plasticVolumeRatio(sp.state, i));
            else
                f.Jp.push_back(1.0f);
        }
        if (a.plasticStrain) {
            if constexpr (requires { M::plasticStrain(sp.state, i); })
                f.plasticStrain.push_back(M::plasticStrain(sp.state, i));
            else
                f.plasticStrain.push_back(0.0f);
        }
    }
    for (std::size_t k = 0; k < a.parameters.size(); ++k) {
        std::vector<float>& column = f.parameters[k].second;
        const Parameter which = parameterNamed(a.parameters[k]);
        if (which == Parameter::Density) {
            // The particle's own: its mass over its rest volume (a point cloud's masses and mass_scale included).
            for (std::size_t i = 0; i < n; ++i) column.push_back(sp.p.mass[i] / sp.p.volume0[i]);
            continue;
        }
        if (!sp.perParticle) {
            column.insert(column.end(), n, parameterValue(sp.params, which));
            continue;
        }
        for (std::size_t i = 0; i < n; ++i) column.push_back(parameterValue(sp.paramsOf(i), which));
    }
}

/// Appends [a, b) of `from` to `to` when `from` holds anything.
template <class T>
void appendRange(std::vector<T>& to, const std::vector<T>& from, std::size_t a, std::size_t b) {
    if (!from.empty()) to.insert(to.end(), from.begin() + std::ptrdiff_t(a), from.begin() + std::ptrdiff_t(b));
}

}  // namespace

PointCloud gatherPoints(const std::vector<AnySpecies>& species, const std::vector<int>& materialOfSpecies,
                        const PointAttributes& attributes) {
    PointCloud f;
    std::size_t n = 0;
    for (const AnySpecies& s : species) n += particlesOf(s).size();
    f.x.reserve(n);
    f.v.reserve(n);
    f.id.reserve(n);
    f.material.reserve(n);
    f.set.reserve(n);
    f.pscale.reserve(n);
    for (const std::string& name : attributes.parameters) f.parameters.emplace_back(name, std::vector<float>{});
    for (std::size_t s = 0; s < species.size(); ++s) {
        const ParticleArrays& P = particlesOf(species[s]);
        f.x.insert(f.x.end(), P.x.begin(), P.x.end());
        f.v.insert(f.v.end(), P.v.begin(), P.v.end());
        f.id.insert(f.id.end(), P.id.begin(), P.id.end());
        f.material.insert(f.material.end(), P.size(), s < materialOfSpecies.size() ? materialOfSpecies[s] : 0);
        f.set.insert(f.set.end(), P.set.begin(), P.set.end());
        if (!attributes.setColours.empty())
            for (uint16_t set : P.set)
                f.Cd.push_back(set < attributes.setColours.size() ? attributes.setColours[set] : Vec3f::Ones());
        std::visit([&](const auto& sp) { appendMaterialAttributes(sp, attributes, f); }, species[s]);
        f.speciesStart.push_back(f.x.size());
    }
    return f;
}

PointCloud PointCloud::subset(const std::vector<int>& species) const {
    PointCloud out;
    for (int s : species) {
        const std::size_t a = speciesStart[s], b = speciesStart[s + 1];
        appendRange(out.x, x, a, b);
        appendRange(out.v, v, a, b);
        appendRange(out.id, id, a, b);
        appendRange(out.material, material, a, b);
        appendRange(out.set, set, a, b);
        appendRange(out.pscale, pscale, a, b);
        appendRange(out.Cd, Cd, a, b);
        appendRange(out.J, J, a, b);
        appendRange(out.Jp, Jp, a, b);
        appendRange(out.stressNorm, stressNorm, a, b);
        appendRange(out.plasticStrain, plasticStrain, a, b);
        appendRange(out.F, F, a, b);
        out.parameters.resize(parameters.size());
        for (std::size_t k = 0; k < parameters.size(); ++k) {
            out.parameters[k].first = parameters[k].first;
            appendRange(out.parameters[k].second, parameters[k].second, a, b);
        }
        out.speciesStart.push_back(out.x.size());
    }
    return out;
}

}  // namespace mpm
