#pragma once
// A scene as users set it up differently: the whole scene turned by a rotation and moved by an offset that is
// no multiple of dx (nor of a level set's voxel). Every position, direction, velocity and turn the scene file
// gives is mapped, so the variant is the same physical scene in other axes; results measured in it, mapped
// back, must agree with the original's to within what the grid's new alignment changes. Tests of colliders
// and contact run their cases through these variants, not only in the one placement their author chose.
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "base/Types.h"

namespace mpm::test {

/// x' = R x + T.
struct RigidMap {
    std::string name;
    Mat3d R = Mat3d::Identity();
    Vec3d T = Vec3d::Zero();

    Vec3d point(const Vec3d& x) const { return R * x + T; }
    Vec3d vector(const Vec3d& v) const { return R * v; }
    Vec3d pointBack(const Vec3d& x) const { return R.transpose() * (x - T); }
    Vec3d vectorBack(const Vec3d& v) const { return R.transpose() * v; }
};

/// The placements every collider and contact test runs in: as written; moved by a fraction of a cell on
/// every axis; and turned about an oblique axis by an angle that lines nothing up with the grid, and moved.
inline std::vector<RigidMap> sceneVariants(double dx) {
    const Vec3d offset = Vec3d(0.37, -0.61, 0.23) * dx;
    const Mat3d turn = Eigen::AngleAxisd(37.0 * M_PI / 180.0, Vec3d(1, 2, 3).normalized()).toRotationMatrix();
    return {RigidMap{"as written", Mat3d::Identity(), Vec3d::Zero()}, RigidMap{"shifted", Mat3d::Identity(), offset},
            RigidMap{"turned and shifted", turn, offset}};
}

namespace detail {

inline Vec3d vec(const nlohmann::json& j) { return Vec3d(j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()); }
inline nlohmann::json arr(const Vec3d& v) { return nlohmann::json::array({v[0], v[1], v[2]}); }

/// A scene rotation {axis, degrees} as a matrix (identity when absent).
inline Mat3d rotationOf(const nlohmann::json& r) {
    if (r.is_null()) return Mat3d::Identity();
    const Vec3d axis = r.contains("axis") ? vec(r["axis"]) : Vec3d(0, 1, 0);
    const double degrees = r.value("degrees", 0.0);
    return Eigen::AngleAxisd(degrees * M_PI / 180.0, axis.normalized()).toRotationMatrix();
}
inline nlohmann::json rotationJson(const Mat3d& m) {
    const Eigen::AngleAxisd a(m);
    return {{"axis", arr(a.axis())}, {"degrees", a.angle() * 180.0 / M_PI}};
}

inline void mapPoint(nlohmann::json& o, const char* key, const RigidMap& m) {
    if (o.contains(key)) o[key] = arr(m.point(vec(o[key])));
}
inline void mapVector(nlohmann::json& o, const char* key, const RigidMap& m) {
    if (o.contains(key)) o[key] = arr(m.vector(vec(o[key])));
}

/// A shape (of a set or a collider) placed by the map. Boxes given by corners become centre, size and rotation.
inline void mapShape(nlohmann::json& s, const RigidMap& m) {
    const std::string type = s.value("type", "box");
    if (type == "box") {
        if (s.contains("min")) {
            const Vec3d lo = vec(s["min"]), hi = vec(s["max"]);
            s.erase("min");
            s.erase("max");
            s["center"] = arr(0.5 * (lo + hi));
            s["size"] = arr(hi - lo);
        }
        const Mat3d turn = m.R * rotationOf(s.value("rotation", nlohmann::json()));
        mapPoint(s, "center", m);
        s["rotation"] = rotationJson(turn);
    } else if (type == "mesh" || type == "vdb" || type == "points") {
        // x = translate + Rt scale x_file, so x' = (R translate + T) + (R Rt) scale x_file.
        nlohmann::json t = s.value("transform", nlohmann::json::object());
        const Vec3d translate = t.contains("translate") ? vec(t["translate"]) : Vec3d::Zero();
        const Mat3d turn = m.R * rotationOf(t.value("rotate", nlohmann::json()));
        t["translate"] = arr(m.point(translate));
        t["rotate"] = rotationJson(turn);
        s["transform"] = t;
    } else {
        // Plane, sphere, cylinder, disc: a point and a direction, each with its default where the scene leaves it out.
        const char* at = type == "plane" ? "point" : "center";
        const char* direction = type == "cylinder" ? "axis" : type == "sphere" ? nullptr : "normal";
        if (!s.contains(at)) s[at] = arr(Vec3d::Zero());
        mapPoint(s, at, m);
        if (direction) {
            if (!s.contains(direction)) s[direction] = arr(Vec3d(0, 1, 0));
            mapVector(s, direction, m);
        }
    }
}

}  // namespace detail

/// The scene `scene` (its JSON) turned and moved by `m`: gravity, every set's shape, velocity, spin and pivot,
/// every collider's shape and motion (velocity, spin, pivot, keyframed positions and turns), and a rigid body's
/// initial velocity and spin (its axis locks name world axes and stay as they are).
inline nlohmann::json transformScene(nlohmann::json scene, const RigidMap& m) {
    using namespace detail;
    nlohmann::json& sim = scene["simulation"];
    sim["gravity"] = arr(m.vector(sim.contains("gravity") ? vec(sim["gravity"]) : Vec3d(0, -9.81, 0)));
    for (nlohmann::json& set : scene["sets"]) {
        if (set.contains("shape")) mapShape(set["shape"], m);
        mapVector(set, "velocity", m);
        mapVector(set, "angular_velocity", m);
        mapPoint(set, "pivot", m);
        if (set.contains("material_fields"))
            for (nlohmann::json& f : set["material_fields"]) mapPoint(f, "from", m), mapPoint(f, "to", m);
    }
    if (!scene.contains("colliders")) return scene;
    for (nlohmann::json& c : scene["colliders"]) {
        mapShape(c, m);
        if (c.contains("dynamic")) {
            mapVector(c["dynamic"], "velocity", m);
            mapVector(c["dynamic"], "angular_velocity", m);
        }
        if (!c.contains("motion")) continue;
        nlohmann::json& motion = c["motion"];
        mapVector(motion, "velocity", m);
        mapVector(motion, "angular_velocity", m);
        mapPoint(motion, "pivot", m);
        if (motion.contains("keyframes"))
            for (nlohmann::json& k : motion["keyframes"]) {
                mapPoint(k, "position", m);
                // A turn q of the rest placement becomes R q R^T in the turned axes.
                if (k.contains("rotation")) k["rotation"] = rotationJson(m.R * rotationOf(k["rotation"]) * m.R.transpose());
            }
    }
    return scene;
}

}  // namespace mpm::test
