#pragma once
// The closed lists of shapes: those that fill particle sets (a finite volume with `contains`, `volume` and
// `bounds`, or a file whose level set's inside is filled) and those that collide (a signed distance, positive
// outside, and its normal; or a file that becomes a level set when the scene is built). Each shape is one file with its formula
// and scene keys; a new one is that file and one entry in a list here.
#include <string>
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

}  // namespace mpm
