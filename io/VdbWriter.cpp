#include "io/VdbWriter.h"

#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>
#include <openvdb/points/AttributeArrayString.h>
#include <openvdb/points/PointConversion.h>
#include <openvdb/points/PointCount.h>
#include <openvdb/points/PointGroup.h>
#include <openvdb/points/PointRasterizeSDF.h>
#include <openvdb/tools/LevelSetFilter.h>
#include <openvdb/tools/LevelSetUtil.h>
#include <nlohmann/json.hpp>

#include <cctype>
#include <map>
#include <stdexcept>
#include <type_traits>

#include "io/AtomicFile.h"

namespace mpm {

namespace {

using openvdb::points::PointDataGrid;

/// One of the cloud's arrays seen through OpenVDB's point-array interface (that of PointAttributeVector),
/// read in place rather than copied into OpenVDB's vector types.
template <class VdbT, class T>
struct ArrayView {
    using PosType = VdbT;
    using value_type = VdbT;
    const std::vector<T>& data;
    static VdbT convert(const T& a) {
        if constexpr (std::is_arithmetic_v<T>)
            return VdbT(a);
        else if constexpr (std::is_same_v<T, std::array<float, 4>>)
            return VdbT(a[0], a[1], a[2], a[3]);
        else if constexpr (std::is_same_v<T, Mat3f>)
            return VdbT(a(0, 0), a(0, 1), a(0, 2), a(1, 0), a(1, 1), a(1, 2), a(2, 0), a(2, 1), a(2, 2));  // row-major both
        else
            return VdbT(a[0], a[1], a[2]);
    }
    std::size_t size() const { return data.size(); }
    void getPos(std::size_t n, VdbT& xyz) const { xyz = convert(data[n]); }
    void get(VdbT& value, std::size_t n) const { value = convert(data[n]); }
    void get(VdbT& value, std::size_t n, openvdb::Index) const { value = convert(data[n]); }
};

template <class VdbT, class Codec = openvdb::points::NullCodec, class T>
void addAttribute(PointDataGrid& grid, const openvdb::tools::PointIndexGrid& index, const char* name,
                  const std::vector<T>& values) {
    openvdb::points::appendAttribute<VdbT, Codec>(grid.tree(), name);
    const ArrayView<VdbT, T> view{values};
    openvdb::points::populateAttribute<openvdb::points::PointDataTree, openvdb::tools::PointIndexTree>(grid.tree(), index.tree(),
                                                                                                       name, view);
}

/// A string attribute: the strings go into the grid's descriptor (as Houdini stores them), each point its index.
void addStringAttribute(PointDataGrid& grid, const openvdb::tools::PointIndexGrid& index, const char* name,
                        const std::vector<std::string>& values) {
    openvdb::points::appendAttribute<std::string>(grid.tree(), name);
    auto leaf = grid.tree().beginLeaf();
    if (!leaf) return;
    openvdb::MetaMap& strings = openvdb::points::makeDescriptorUnique(grid.tree())->getMetadata();
    openvdb::points::StringMetaInserter inserter(strings);
    for (const std::string& v : values) inserter.insert(v);
    for (; leaf; ++leaf) {
        // The points of a leaf are stored in its index leaf's order.
        const auto* order = index.tree().probeConstLeaf(leaf->origin());
        if (!order) continue;
        openvdb::points::StringAttributeWriteHandle handle(leaf->attributeArray(name), strings);
        for (std::size_t n = 0; n < order->indices().size(); ++n) handle.set(openvdb::Index(n), values[order->indices()[n]]);
    }
}

/// A point group name Houdini accepts (letters, digits and underscores) for a material or set name: other
/// characters become underscores, and a clash with an earlier group gets the index appended.
std::string groupName(const std::string& prefix, const std::string& name, std::size_t index,
                      const std::map<std::string, std::string>& taken) {
    std::string g = prefix;
    for (char c : name) g += (std::isalnum(static_cast<unsigned char>(c)) || c == '_') ? c : '_';
    if (taken.count(g)) g += "_" + std::to_string(index);
    return g;
}

/// One point group per material and per set present (`material_water`, `set_<name>`), and the map from each
/// group to the name it stands for (stored as metadata: the names themselves may hold any string).
std::map<std::string, std::string> addGroups(PointDataGrid& grid, const openvdb::tools::PointIndexGrid& index,
                                             const PointCloud& f, const std::vector<std::string>& materialNames,
                                             const std::vector<std::string>& setNames) {
    std::map<std::string, std::string> groups;
    auto add = [&](const char* prefix, const std::vector<std::string>& names, const std::vector<int32_t>& of) {
        std::vector<bool> present(names.size(), false);
        for (int32_t k : of)
            if (k >= 0 && std::size_t(k) < names.size()) present[std::size_t(k)] = true;
        for (std::size_t k = 0; k < names.size(); ++k) {
            if (!present[k]) continue;
            const std::string g = groupName(prefix, names[k], k, groups);
            groups[g] = names[k];
            std::vector<short> member(of.size());
            for (std::size_t i = 0; i < of.size(); ++i) member[i] = of[i] == int32_t(k);
            openvdb::points::appendGroup(grid.tree(), g);
            openvdb::points::setGroup(grid.tree(), index.tree(), member, g);
        }
    };
    add("material_", materialNames, f.material);
    add("set_", setNames, f.set);
    return groups;
}

/// Points with P (16-bit fixed point, as Houdini writes them) and, when full, v, id, material, set, pscale,
/// the attributes the cloud carries and the groups.
PointDataGrid::Ptr makePoints(const PointCloud& f, double voxelSize, const VdbFrameRequest* full) {
    const auto xform = openvdb::math::Transform::createLinearTransform(voxelSize);
    const ArrayView<openvdb::Vec3d, Vec3d> positions{f.x};
    auto index = openvdb::tools::createPointIndexGrid<openvdb::tools::PointIndexGrid>(positions, *xform);
    auto grid =
        openvdb::points::createPointDataGrid<openvdb::points::FixedPointCodec<false>, PointDataGrid>(*index, positions, *xform);
    if (full) {
        addAttribute<openvdb::Vec3s>(*grid, *index, "v", f.v);
        addAttribute<int32_t>(*grid, *index, "id", f.id);
        addAttribute<int32_t>(*grid, *index, "material", f.material);
        addAttribute<int32_t>(*grid, *index, "set", f.set);
        if (!f.pscale.empty()) addAttribute<float>(*grid, *index, "pscale", f.pscale);
        if (!f.Cd.empty()) addAttribute<openvdb::Vec3s>(*grid, *index, "Cd", f.Cd);
        if (!f.J.empty()) addAttribute<float>(*grid, *index, "J", f.J);
        if (!f.Jp.empty()) addAttribute<float>(*grid, *index, "Jp", f.Jp);
        if (!f.stressNorm.empty()) addAttribute<float>(*grid, *index, "stress_norm", f.stressNorm);
        if (!f.plasticStrain.empty()) addAttribute<float>(*grid, *index, "plastic_strain", f.plasticStrain);
        if (!f.F.empty()) addAttribute<openvdb::math::Mat3s>(*grid, *index, "F", f.F);
        for (const auto& [name, values] : f.parameters) addAttribute<float>(*grid, *index, name.c_str(), values);
        const auto groups = addGroups(*grid, *index, f, full->materialNames, full->setNames);
        grid->insertMeta("group_names", openvdb::StringMetadata(nlohmann::json(groups).dump()));
    }
    return grid;
}

/// One point per rigid body (BodyPoints), positions at full precision (a body's pose is read, not rendered
/// from), in voxels of the points grid's size.
PointDataGrid::Ptr makeBodies(const BodyPoints& b, double voxelSize) {
    const auto xform = openvdb::math::Transform::createLinearTransform(voxelSize);
    const ArrayView<openvdb::Vec3d, Vec3d> positions{b.x};
    auto index = openvdb::tools::createPointIndexGrid<openvdb::tools::PointIndexGrid>(positions, *xform);
    auto grid = openvdb::points::createPointDataGrid<openvdb::points::NullCodec, PointDataGrid>(*index, positions, *xform);
    addAttribute<openvdb::math::Quats>(*grid, *index, "orient", b.orient);
    addAttribute<openvdb::Vec3s>(*grid, *index, "v", b.v);
    addAttribute<openvdb::Vec3s>(*grid, *index, "w", b.w);
    addAttribute<int32_t>(*grid, *index, "collider", b.collider);
    addStringAttribute(*grid, *index, "name", b.name);
    grid->setName("bodies");
    return grid;
}

/// Names as a JSON array in a string: any name survives, commas, quotes and all.
std::string jsonArray(const std::vector<std::string>& v) { return nlohmann::json(v).dump(); }

/// Writes the grids through OpenVDB's stream writer into a checked atomic file (io/AtomicFile.h): a full disk
/// is an error naming the file, never a truncated frame under its final name.
void writeFile(const std::string& path, const openvdb::GridPtrVec& grids) {
    writeAtomically(path, [&](std::ostream& out) {
        openvdb::io::Stream stream(out);
        stream.setCompression(openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK);
        openvdb::MetaMap meta;
        meta.insertMeta("up_axis", openvdb::StringMetadata("y"));
        meta.insertMeta("units", openvdb::StringMetadata("SI (m, m/s)"));
        stream.write(grids, meta);
    });
}

/// Closes and smooths a surface as Houdini's particle-fluid surfacing does: dilate (fills the gaps between the
/// spheres in the bulk), Gaussian passes (flatten the bumps each sphere leaves), erode (back to where the material
/// is). The filter keeps the narrow band a signed distance as it moves the surface (its level-set tracker).
void filterSurface(openvdb::FloatGrid& sdf, const VdbFrameRequest& r) {
    if (r.surfaceDilate <= 0.0 && r.surfaceErode <= 0.0 && r.surfaceSmooth <= 0) return;
    openvdb::tools::LevelSetFilter<openvdb::FloatGrid> filter(sdf);
    // The tracker renormalises after each half-voxel move and box pass (12 times with the defaults). First-order
    // upwind differences do that 2.9x faster than its default WENO5 and gave a flatter pool and a truer ball
    // (docs/method.md, section 12: Surfaces).
    filter.setSpatialScheme(openvdb::math::FIRST_BIAS);
    const float voxel = float(sdf.voxelSize()[0]);
    if (r.surfaceDilate > 0.0) filter.offset(-float(r.surfaceDilate) * voxel);  // phi + offset: negative grows
    for (int i = 0; i < r.surfaceSmooth; ++i) filter.gaussian(1);
    if (r.surfaceErode > 0.0) filter.offset(float(r.surfaceErode) * voxel);
}

/// Mean particle velocity per surface voxel.
openvdb::Vec3SGrid::Ptr velocityGrid(const PointCloud& f, double voxelSize) {
    auto grid = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
    grid->setTransform(openvdb::math::Transform::createLinearTransform(voxelSize));
    openvdb::FloatGrid counts(0.0f);
    auto acc = grid->getAccessor();
    auto cnt = counts.getAccessor();
    for (std::size_t i = 0; i < f.x.size(); ++i) {
        const openvdb::Coord c = grid->transform().worldToIndexNodeCentered(openvdb::Vec3d(f.x[i][0], f.x[i][1], f.x[i][2]));
        acc.setValue(c, acc.getValue(c) + openvdb::Vec3s(f.v[i][0], f.v[i][1], f.v[i][2]));
        cnt.setValue(c, cnt.getValue(c) + 1.0f);
    }
    for (auto it = grid->beginValueOn(); it; ++it) it.setValue(*it / cnt.getValue(it.getCoord()));
    grid->setName("vel");
    grid->setVectorType(openvdb::VEC_CONTRAVARIANT_RELATIVE);
    return grid;
}

}  // namespace

std::size_t writeVdbFrame(const VdbFrameRequest& r, const PointCloud& flat) {
    openvdb::initialize();
    const std::size_t speciesCount = flat.speciesStart.size() - 1;
    openvdb::GridPtrVec volumes, pointGrids;
    if (r.points) {
        auto points = makePoints(flat, r.pointVoxelSize, &r);
        points->setName("points");
        points->insertMeta("material_names", openvdb::StringMetadata(jsonArray(r.materialNames)));
        points->insertMeta("set_names", openvdb::StringMetadata(jsonArray(r.setNames)));
        (r.pointsPath.empty() ? volumes : pointGrids).push_back(points);
    }
    if (r.surface || r.density) {
        for (const SurfaceGroup& g : r.surfaces) {
            const bool all = g.species.size() == speciesCount;  // groups list distinct species
            const PointCloud part = all ? PointCloud() : flat.subset(g.species);
            const PointCloud& src = all ? flat : part;
            if (src.x.empty()) continue;
            auto pts = makePoints(src, r.pointVoxelSize, nullptr);
            auto xform = openvdb::math::Transform::createLinearTransform(r.surfaceVoxelSize);
            // Zhu and Bridson 2005 smoothed spheres, then closed and smoothed (docs/method.md, section 12).
            auto sdf = openvdb::points::rasterizeSmoothSpheres(*pts, r.surfaceRadius, 2.0 * r.surfaceRadius,
                                                               openvdb::LEVEL_SET_HALF_WIDTH, xform);
            sdf->setGridClass(openvdb::GRID_LEVEL_SET);
            filterSurface(*sdf, r);
            if (r.density) {
                auto fog = sdf->deepCopy();
                openvdb::tools::sdfToFogVolume(*fog);
                fog->setName(g.gridName == "surface" ? "density" : "density" + g.gridName.substr(7));
                volumes.push_back(fog);
            }
            if (r.surface) {
                sdf->setName(g.gridName);
                volumes.push_back(sdf);
            }
        }
    }
    if (r.velocity && !flat.x.empty()) volumes.push_back(velocityGrid(flat, r.surfaceVoxelSize));
    // Beside the points (Blender reads a volume file only while it holds no point grid).
    if (r.points && !r.bodies.x.empty())
        (r.pointsPath.empty() ? volumes : pointGrids).push_back(makeBodies(r.bodies, r.pointVoxelSize));
    if (!pointGrids.empty()) writeFile(r.pointsPath, pointGrids);
    if (!volumes.empty() || r.pointsPath.empty()) writeFile(r.volumePath, volumes);
    return flat.x.size();
}

PointsReadBack readVdbPoints(const std::string& path) {
    openvdb::initialize();
    openvdb::io::File file(path);
    file.open();
    auto base = file.readGrid("points");
    file.close();
    auto grid = openvdb::gridPtrCast<PointDataGrid>(base);
    if (!grid) throw std::runtime_error(path + ": grid \"points\" is not a PointDataGrid");
    PointsReadBack out;
    auto names = [&](const char* key) {
        const auto meta = grid->getMetadata<openvdb::StringMetadata>(key);
        return meta ? nlohmann::json::parse(meta->value()).get<std::vector<std::string>>() : std::vector<std::string>{};
    };
    out.materialNames = names("material_names");
    out.setNames = names("set_names");
    if (const auto meta = grid->getMetadata<openvdb::StringMetadata>("group_names"))
        out.groupNames = nlohmann::json::parse(meta->value()).get<std::map<std::string, std::string>>();
    for (const auto& [group, name] : out.groupNames) out.groups[group];
    for (auto leaf = grid->tree().cbeginLeaf(); leaf; ++leaf) {
        openvdb::points::AttributeHandle<openvdb::Vec3f> P(leaf->constAttributeArray("P"));
        openvdb::points::AttributeHandle<openvdb::Vec3f> v(leaf->constAttributeArray("v"));
        openvdb::points::AttributeHandle<int32_t> id(leaf->constAttributeArray("id"));
        openvdb::points::AttributeHandle<int32_t> mat(leaf->constAttributeArray("material"));
        openvdb::points::AttributeHandle<int32_t> set(leaf->constAttributeArray("set"));
        using FloatHandle = openvdb::points::AttributeHandle<float>;
        auto optional = [&](const char* name) {
            return leaf->hasAttribute(name) ? std::make_unique<FloatHandle>(leaf->constAttributeArray(name)) : nullptr;
        };
        const auto pscale = optional("pscale"), J = optional("J"), Jp = optional("Jp"), stress = optional("stress_norm"),
                   plastic = optional("plastic_strain");
        std::unique_ptr<openvdb::points::AttributeHandle<openvdb::Vec3f>> Cd;
        if (leaf->hasAttribute("Cd"))
            Cd = std::make_unique<openvdb::points::AttributeHandle<openvdb::Vec3f>>(leaf->constAttributeArray("Cd"));
        std::unique_ptr<openvdb::points::AttributeHandle<openvdb::math::Mat3s>> F;
        if (leaf->hasAttribute("F"))
            F = std::make_unique<openvdb::points::AttributeHandle<openvdb::math::Mat3s>>(leaf->constAttributeArray("F"));
        // Columns first, then pointers to them: adding a column moves the others.
        const auto columnOf = [&](const std::string& name) {
            return std::find_if(out.parameters.begin(), out.parameters.end(), [&](const auto& c) { return c.first == name; });
        };
        for (const std::string& name : PointAttributes::parameterNames())
            if (leaf->hasAttribute(name) && columnOf(name) == out.parameters.end()) out.parameters.push_back({name, {}});
        std::vector<std::pair<std::vector<float>*, std::unique_ptr<FloatHandle>>> parameters;
        for (const std::string& name : PointAttributes::parameterNames())
            if (leaf->hasAttribute(name)) parameters.emplace_back(&columnOf(name)->second, optional(name.c_str()));
        std::vector<std::pair<std::vector<bool>*, openvdb::points::GroupHandle>> groups;
        for (auto& [group, members] : out.groups)
            if (leaf->attributeSet().descriptor().hasGroup(group)) groups.emplace_back(&members, leaf->groupHandle(group));
        for (auto it = leaf->beginIndexOn(); it; ++it) {
            const openvdb::Vec3d world = grid->transform().indexToWorld(P.get(*it) + it.getCoord().asVec3d());
            out.x.emplace_back(world[0], world[1], world[2]);
            const openvdb::Vec3f vel = v.get(*it);
            out.v.emplace_back(vel[0], vel[1], vel[2]);
            out.id.push_back(id.get(*it));
            out.material.push_back(mat.get(*it));
            out.set.push_back(set.get(*it));
            if (pscale) out.pscale.push_back(pscale->get(*it));
            if (J) out.J.push_back(J->get(*it));
            if (Jp) out.Jp.push_back(Jp->get(*it));
            if (stress) out.stressNorm.push_back(stress->get(*it));
            if (plastic) out.plasticStrain.push_back(plastic->get(*it));
            if (Cd) {
                const openvdb::Vec3f c = Cd->get(*it);
                out.Cd.emplace_back(c[0], c[1], c[2]);
            }
            if (F) {
                const openvdb::math::Mat3s m = F->get(*it);
                Mat3f e;
                for (int r = 0; r < 3; ++r)
                    for (int c = 0; c < 3; ++c) e(r, c) = m(r, c);
                out.F.push_back(e);
            }
            for (auto& [column, handle] : parameters) column->push_back(handle->get(*it));
            for (auto& [members, handle] : groups) members->push_back(handle.get(*it));
        }
    }
    return out;
}

BodyPoints readVdbBodies(const std::string& path) {
    openvdb::initialize();
    openvdb::io::File file(path);
    file.open();
    BodyPoints out;
    if (!file.hasGrid("bodies")) return out;
    auto grid = openvdb::gridPtrCast<PointDataGrid>(file.readGrid("bodies"));
    file.close();
    if (!grid) throw std::runtime_error(path + ": grid \"bodies\" is not a PointDataGrid");
    for (auto leaf = grid->tree().cbeginLeaf(); leaf; ++leaf) {
        openvdb::points::AttributeHandle<openvdb::Vec3f> P(leaf->constAttributeArray("P"));
        openvdb::points::AttributeHandle<openvdb::math::Quats> orient(leaf->constAttributeArray("orient"));
        openvdb::points::AttributeHandle<openvdb::Vec3f> v(leaf->constAttributeArray("v")), w(leaf->constAttributeArray("w"));
        openvdb::points::AttributeHandle<int32_t> collider(leaf->constAttributeArray("collider"));
        const openvdb::points::AttributeArray* names = leaf->attributeSet().getConst("name");
        std::unique_ptr<openvdb::points::StringAttributeHandle> name;
        if (names)
            name =
                std::make_unique<openvdb::points::StringAttributeHandle>(*names, leaf->attributeSet().descriptor().getMetadata());
        for (auto it = leaf->beginIndexOn(); it; ++it) {
            const openvdb::Vec3d world = grid->transform().indexToWorld(P.get(*it) + it.getCoord().asVec3d());
            out.x.emplace_back(world[0], world[1], world[2]);
            const openvdb::math::Quats q = orient.get(*it);
            out.orient.push_back({q.x(), q.y(), q.z(), q.w()});
            const openvdb::Vec3f a = v.get(*it), b = w.get(*it);
            out.v.emplace_back(a[0], a[1], a[2]);
            out.w.emplace_back(b[0], b[1], b[2]);
            out.collider.push_back(collider.get(*it));
            out.name.push_back(name ? name->get(*it) : std::string());
        }
    }
    return out;
}

std::vector<std::string> vdbGridNames(const std::string& path) {
    openvdb::initialize();
    openvdb::io::File file(path);
    file.open();
    std::vector<std::string> names;
    for (auto it = file.beginName(); it != file.endName(); ++it) names.push_back(*it);
    file.close();
    return names;
}

}  // namespace mpm
