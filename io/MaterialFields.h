#pragma once
// Material parameters given particle by particle (a set's `material_fields`): a stiffness or a density that varies
// through a body. Each particle's parameters are made as the set's are, from its material_params numbers, with each
// field's value at the particle in place of that key's number; the set's Lame scales then apply as they do to the set.
#include <vector>

#include "core/Comm.h"
#include "core/Species.h"
#include "io/SceneBuilder.h"

namespace mpm {

struct FieldParams {
    AnyParamsArray local;  ///< one parameter set per particle, in the samples' order
    /// The particles' parameters with the fastest wave at rest over every rank's part (ties: the smaller bytes), the
    /// same on any rank count: the species keeps them for the CFL bound.
    AnyMaterialParams stiffest;
    std::vector<float> densities;  ///< each particle's density when a field gives it; else empty
};

/// The parameters of the set's particles `samples` (this rank's part of them). Errors (SceneError) name the field
/// and, for a value out of the parameter's range, the first such particle's position and the allowed range.
/// Collective on `comm`.
FieldParams fieldParams(const SetEntry& set, const SetSamples& samples, const Comm& comm);

}  // namespace mpm
