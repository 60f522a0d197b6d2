#pragma once
// The closed lists of shapes: those that fill particle sets (a finite volume with `contains`, `volume` and
// `bounds`, or a file whose level set's inside is filled) and those that collide (a signed distance, positive
// outside, and its normal; or a file that becomes a level set when the scene is built). Each shape is one file with its formula
// and scene keys; a new one is that file and one entry in a list here.
#include <concepts>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>

#include "core/shapes/Box.h"
#include "core/shapes/Cylinder.h"
#include "core/shapes/Disc.h"
#include "core/shapes/FileShapes.h"
#include "core/shapes/Plane.h"
#include "core/shapes/Rectangle.h"
#include "core/shapes/Sphere.h"

namespace mpm {

using SetShape = std::variant<Box, Sphere, Cylinder, MeshShape, VdbShape, PointsShape, Disc, Rectangle>;
using ColliderShape = std::variant<Plane, Sphere, Box, Cylinder, MeshShape, VdbShape>;

/// The `type` names of a list's shapes, in order.
template <class... S>
std::vector<std::string> shapeTypeNames(const std::variant<S...>*) {
    return {S::kType...};
}

/// Sets `out` to the default shape whose kType is `type`; false when none is.
template <class... S>
bool shapeOfType(const std::string& type, std::variant<S...>& out) {
    bool found = false;
    ((!found && type == S::kType ? (out = S{}, found = true) : false), ...);
    return found;
}

/// Whether a shape is a surface that a continuous source flows in through (an outlet), not a volume.
template <class S>
inline constexpr bool kOutlet = std::is_same_v<S, Disc> || std::is_same_v<S, Rectangle>;
inline bool isOutlet(const SetShape& s) {
    return std::visit([]<class S>(const S&) { return kOutlet<S>; }, s);
}

/// Whether a shape has a formula (analytic) or comes from a file.
template <class S>
inline constexpr bool kFromFile = std::is_same_v<S, MeshShape> || std::is_same_v<S, VdbShape>;

/// The contract of a shape: its `type` name and its scene keys (base/Parameters.h), and by its role in the lists
/// above, a volume sets fill, a surface colliders are made of, or neither (a file, read into a level set by
/// io/LevelSets.cpp; a point cloud; an outlet, with kOutlet).
template <class S>
concept SceneShape = HasSceneKeys<S> && requires {
    { S::kType } -> std::convertible_to<const char*>;
};
/// A volume a set fills: whether a point is inside, its volume [m^3] and its axis-aligned bounds.
template <class S>
concept FillableVolume = SceneShape<S> && requires(const S& s, const Vec3d& x, Vec3d& lo, Vec3d& hi) {
    { s.contains(x) } -> std::same_as<bool>;
    { s.volume() } -> std::convertible_to<double>;
    s.bounds(lo, hi);
};
/// A collider's surface: a signed distance (positive outside, 1-Lipschitz), its outward normal, and the middle
/// that a keyframed motion without a pivot turns it about.
template <class S>
concept ColliderSurface = SceneShape<S> && requires(const S& s, const Vec3d& x) {
    { s.signedDistance(x) } -> std::convertible_to<double>;
    { s.normalAt(x) } -> std::convertible_to<Vec3d>;
    { s.middle() } -> std::convertible_to<Vec3d>;
};
/// A set's shape with a formula (not a file, a point cloud or an outlet): sampling fills it.
template <class S>
inline constexpr bool kAnalyticVolume = !kFromFile<S> && !kOutlet<S> && !std::is_same_v<S, PointsShape>;

template <class S>
constexpr bool checkSetShape() {
    static_assert(SceneShape<S> && (!kAnalyticVolume<S> || FillableVolume<S>),
                  "a set's shape meets the contract in core/shapes/Shapes.h: kType, keys, and for a volume with a formula "
                  "contains, volume and bounds");
    return true;
}
template <class S>
constexpr bool checkColliderShape() {
    static_assert(SceneShape<S> && (kFromFile<S> || ColliderSurface<S>),
                  "a collider's shape meets the contract in core/shapes/Shapes.h: kType, keys, and for a shape with a "
                  "formula signedDistance, normalAt and middle");
    return true;
}
/// Whether the `type` names of a list's shapes differ: a scene picks its shape by that name.
template <class... S>
constexpr bool typeNamesUnique(const std::variant<S...>*) {
    return namesDistinct({S::kType...});
}
static_assert(typeNamesUnique(static_cast<SetShape*>(nullptr)), "two set shapes share a kType");
static_assert(typeNamesUnique(static_cast<ColliderShape*>(nullptr)), "two collider shapes share a kType");
static_assert([]<class... S>(std::variant<S...>*) { return (checkSetShape<S>() && ...); }(static_cast<SetShape*>(nullptr)));
static_assert([]<class... S>(std::variant<S...>*) {
    return (checkColliderShape<S>() && ...);
}(static_cast<ColliderShape*>(nullptr)));

}  // namespace mpm
