#pragma once
// Initial particle positions inside a shape: Poisson-disk sampling (Bridson 2007, "Fast Poisson disk
// sampling in arbitrary dimensions"), as the thesis did, or a jittered lattice.
#include <vector>

#include "io/SceneDesc.h"

namespace mpm {

/// Fraction of a lattice spacing by which grid sampling jitters each point (keeps min spacing > 0.5 s).
inline constexpr double kGridJitter = 0.25;
/// Bridson's candidate count per active sample.
inline constexpr int kPoissonAttempts = 30;

/// Samples the shape. With count > 0 exactly count points are returned (a random subset of a denser
/// sampling, which keeps the minimum spacing); otherwise particlesPerCell sets the density.
std::vector<Vec3d> sampleShape(const SetShape& shape, double dx, double particlesPerCell, long long count, Sampling method,
                               unsigned seed);

/// Poisson-disk samples with minimum distance r inside the shape.
std::vector<Vec3d> poissonDisk(const SetShape& shape, double r, unsigned seed);

/// The shape's volume [m^3].
double shapeVolume(const SetShape& shape);

/// Minimum distance used for a target density of n points per unit volume: Bridson's method fills space
/// at about 1 / (kPoissonPacking r^3) points per volume (measured here: 1.75-1.8 for 3D with 30 attempts).
inline constexpr double kPoissonPacking = 1.75;

}  // namespace mpm
