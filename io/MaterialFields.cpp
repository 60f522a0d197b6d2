#include "io/MaterialFields.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>
#include <string>

#include "io/LevelSets.h"

namespace mpm {

namespace {

/// A key visitor (base/Parameters.h) that makes one particle's parameters as the scene reader made the set's: a key
/// a field gives takes the field's value, a key the scene gives its number, and the rest their defaults or what the
/// material derives from the others (a viscous liquid's shear modulus from its bulk modulus).
struct ParticleKeys : KeyVisitorArchetype {
    const std::vector<std::pair<std::string, double>>& numbers;
    const std::vector<MaterialFieldDesc>& fields;
    const double* values = nullptr;  ///< this particle's, one per field
    int outOfRange = -1;             ///< the first field whose value lies outside its key's range
    double lo = 0.0, hi = 0.0;       ///< that key's range

    ParticleKeys(const std::vector<std::pair<std::string, double>>& n, const std::vector<MaterialFieldDesc>& f)
        : numbers(n), fields(f) {}
    template <class T>
    void number(const Key& k, T& value) {
        for (std::size_t f = 0; f < fields.size(); ++f)
            if (fields[f].param == k.name) {
                const double v = values[f];
                if (!(v >= k.lo && v <= k.hi) && outOfRange < 0) outOfRange = int(f), lo = k.lo, hi = k.hi;
                value = T(v);
                return;
            }
        for (const auto& [name, v] : numbers)
            if (name == k.name) {
                value = T(v);
                return;
            }
    }
    bool given(std::string_view key) const {
        for (const MaterialFieldDesc& f : fields)
            if (f.param == key) return true;
        for (const auto& n : numbers)
            if (n.first == key) return true;
        return false;
    }
    // Nested keys see this visitor, not the archetype it builds on.
    template <class F>
    void object(const Key&, F&& f) {
        f(*this);
    }
    template <class T, class F>
    void list(const Key&, std::vector<T>& items, F&& f) {
        for (T& item : items) f(*this, item);
    }
};

/// Field f's value at each sample.
std::vector<double> fieldValues(const SetEntry& set, std::size_t f, const SetSamples& samples) {
    const MaterialFieldDesc& d = set.desc().materialFields[f];
    const std::string key = "material_fields/" + std::to_string(f);
    const std::vector<Vec3d>& x = samples.positions;
    switch (d.source) {
        case MaterialFieldDesc::Source::Ramp: {
            // Linear along from -> to, held at the end values beyond them.
            const Vec3d axis = d.to - d.from;
            std::vector<double> out(x.size());
            for (std::size_t p = 0; p < x.size(); ++p) {
                const double t = std::clamp((x[p] - d.from).dot(axis) / axis.squaredNorm(), 0.0, 1.0);
                out[p] = d.fromValue + t * (d.toValue - d.fromValue);
            }
            return out;
        }
        case MaterialFieldDesc::Source::Vdb:
            try {
                return vdbScalarSamples(besideScene(set.scene, d.file), d.grid, x);
            } catch (const LevelSetError& e) {
                throw SceneError(set.at(key + "/file") + ": " + e.what());
            }
        case MaterialFieldDesc::Source::Attribute: {
            if (!std::holds_alternative<PointsShape>(set.desc().shape))
                throw SceneError(set.at(key + "/source") +
                                 ": an attribute field reads a vertex property of a points set's PLY "
                                 "file; this set's shape is no point cloud (use ramp or vdb)");
            std::size_t column = 0;
            for (std::size_t k = 0; k < f; ++k)
                column += set.desc().materialFields[k].source == MaterialFieldDesc::Source::Attribute;
            const std::vector<float>& c = samples.columns.at(column);
            return std::vector<double>(c.begin(), c.end());
        }
    }
    throw std::logic_error("fieldValues: unknown source");
}

std::string formatNumber(double v) {
    std::ostringstream s;
    s << v;
    return s.str();
}

}  // namespace

FieldParams fieldParams(const SetEntry& set, const SetSamples& samples, const Comm& comm) {
    const ParticleSetDesc& d = set.desc();
    const std::size_t n = samples.positions.size(), fields = d.materialFields.size();
    std::vector<std::vector<double>> values;
    for (std::size_t f = 0; f < fields; ++f) values.push_back(fieldValues(set, f, samples));
    const auto density = std::find_if(d.materialFields.begin(), d.materialFields.end(),
                                      [](const MaterialFieldDesc& f) { return f.param == "density"; });
    if (density != d.materialFields.end() && !samples.masses.empty())
        throw SceneError(set.at("material_fields/" + std::to_string(density - d.materialFields.begin())) +
                         ": the point cloud gives its points' masses (or densities); a density field would contradict them");
    FieldParams out;
    visitMaterialParams(d.params, [&]<class M>(const typename M::Params& setParams) {
        using Params = typename M::Params;
        // The wave speed at rest: the rest state's stiffness key, as the set's parameters give it.
        typename M::State rest;
        if constexpr (requires { rest.appendRest(1, setParams); })
            rest.appendRest(1, setParams);
        else
            rest.appendRest(1);
        const float restKey = M::stiffnessKey(rest, 0);
        std::vector<Params> local(n, setParams);
        std::vector<double> at(fields);
        ParticleKeys keys{d.materialNumbers, d.materialFields};
        for (std::size_t p = 0; p < n; ++p) {
            for (std::size_t f = 0; f < fields; ++f) at[f] = values[f][p];
            keys.values = at.data();
            M::keys(keys, local[p]);
            if (keys.outOfRange >= 0) {
                const MaterialFieldDesc& f = d.materialFields[std::size_t(keys.outOfRange)];
                const Vec3d& x = samples.positions[p];
                throw SceneError(set.at("material_fields/" + std::to_string(keys.outOfRange)) + ": " + f.param + " = " +
                                 formatNumber(at[std::size_t(keys.outOfRange)]) + " at the particle at (" + formatNumber(x[0]) +
                                 ", " + formatNumber(x[1]) + ", " + formatNumber(x[2]) +
                                 ") m; allowed: " + formatNumber(keys.lo) + " to " + formatNumber(keys.hi));
            }
            M::scaleStiffness(local[p], d.lambdaScale, d.muScale);
        }
        // The stiffest particle of this part, then of all parts, by the same rule: the same bits on any rank count.
        auto stiffer = [&](const Params& a, const Params& b) {
            const float wa = M::waveSpeed(a, restKey), wb = M::waveSpeed(b, restKey);
            return wa != wb ? wa > wb : std::memcmp(&a, &b, sizeof(Params)) < 0;
        };
        Params stiffest = setParams;
        M::scaleStiffness(stiffest, d.lambdaScale, d.muScale);
        bool any = false;
        for (const Params& p : local)
            if (!any || stiffer(p, stiffest)) stiffest = p, any = true;
        Bytes mine;
        put(mine, uint8_t(any));
        put(mine, stiffest);
        bool found = false;
        for (const Bytes& b : comm.allGather(mine)) {
            ByteReader r{b};
            const bool has = r.get<uint8_t>() != 0;
            const Params p = r.get<Params>();
            if (has && (!found || stiffer(p, stiffest))) stiffest = p, found = true;
        }
        out.stiffest = stiffest;
        if (density != d.materialFields.end())
            for (const Params& p : local) out.densities.push_back(p.density);
        out.local = std::move(local);
    });
    return out;
}

}  // namespace mpm
