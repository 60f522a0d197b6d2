#pragma once
// Initial particle positions inside a shape: Poisson-disk sampling (Bridson 2007, "Fast Poisson disk
// sampling in arbitrary dimensions"), as the thesis did, or a jittered lattice.
#include <atomic>
#include <cstddef>
#include <memory>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "core/LevelSet.h"
#include "io/SceneDesc.h"

namespace mpm {

/// The inside of a level set (phi < 0), as a region to sample: a set filled from a mesh or a VDB file.
class LevelSetInside {
public:
    /// `volume`: what is inside the zero crossing [m^3].
    LevelSetInside(std::shared_ptr<const LevelSet> ls, double volume)
        : ls_(std::move(ls)), sampler_(std::make_shared<LevelSet::Sampler>(*ls_)), volume_(volume) {}
    void bounds(Vec3d& lo, Vec3d& hi) const { ls_->bounds(lo, hi); }
    /// Serial: the sampler is shared by copies of this region (a task takes its own: withOwnSampler).
    bool contains(const Vec3d& x) const { return sampler_->phi(x) < 0.0; }
    LevelSetInside withOwnSampler() const { return LevelSetInside(ls_, volume_); }
    /// True when no point of the world box [lo, hi] is inside (a cheap test: see LevelSet::Sampler::outside).
    bool outside(const Vec3d& lo, const Vec3d& hi) const { return sampler_->outside(lo, hi); }
    double volume() const { return volume_; }
    /// A mesh or a VDB may hold several pieces, thin ones among them: Poisson-disk sampling seeds each one.
    static constexpr bool kMayBeDisconnected = true;

private:
    std::shared_ptr<const LevelSet> ls_;
    std::shared_ptr<LevelSet::Sampler> sampler_;
    double volume_;
};

namespace sampling_detail {
/// The set shapes with a formula (kAnalyticVolume), in SetShape's order, then `Last`.
template <class Kept, class Last, class... S>
struct Regions;
template <class... K, class Last>
struct Regions<std::variant<K...>, Last> {
    using type = std::variant<K..., Last>;
};
template <class... K, class Last, class S, class... Rest>
struct Regions<std::variant<K...>, Last, S, Rest...> {
    using type =
        typename Regions<std::conditional_t<kAnalyticVolume<S>, std::variant<K..., S>, std::variant<K...>>, Last, Rest...>::type;
};
template <class Shapes>
struct RegionsOf;
template <class... S>
struct RegionsOf<std::variant<S...>> {
    using type = typename Regions<std::variant<>, LevelSetInside, S...>::type;
};
}  // namespace sampling_detail

/// What sampling fills: a set's shape with a formula (every such shape of SetShape), or the inside of a file's level
/// set.
using SetRegion = sampling_detail::RegionsOf<SetShape>::type;

/// Fraction of a lattice spacing by which grid sampling jitters each point (keeps min spacing > 0.5 s).
inline constexpr double kGridJitter = 0.25;
/// Bridson's candidate count per active sample.
inline constexpr int kPoissonAttempts = 30;

/// Which share of a set's samples a caller takes (a rank's): part `part` of `parts`. The parts, concatenated
/// in order, are the whole sampling in its order.
struct SamplePart {
    int part = 0, parts = 1;
    /// A stop request (mpm run's signal flag): while it is nonzero the sampling gives up, throwing Interrupted,
    /// within a few milliseconds, so that Ctrl-C ends the set-up of a scene of millions of particles at once.
    const std::atomic<int>* stop = nullptr;
    void checkStop() const;
    /// The part's items [first, second) of n in order: the part-th of `parts` nearly equal ranges.
    std::pair<std::size_t, std::size_t> range(std::size_t n) const {
        const auto cut = [&](int k) {
            return std::size_t((unsigned long long)n * (unsigned long long)k / (unsigned long long)parts);
        };
        return {cut(part), cut(part + 1)};
    }
};

/// Samples the shape. With count > 0 exactly count points are returned (a random subset of a denser
/// sampling, which keeps the minimum spacing); otherwise particlesPerCell sets the density. A set given by
/// its density holds only its part's points (a Poisson-disk set samples only its part's tiles); one given by
/// its count is sampled whole and then cut. Throws std::domain_error when the shape holds fewer than count points
/// even at 8 times the density its volume implies, and std::length_error when it spans too many Poisson tiles.
std::vector<Vec3d> sampleShape(const SetRegion& shape, double dx, double particlesPerCell, long long count, Sampling method,
                               unsigned seed, SamplePart part = {});

/// Poisson-disk samples with minimum distance r inside the shape, sampled in tiles (Bridson's growth in
/// phases of tiles, after Wei 2008): part k of n is the k-th n-th of the tiles in Morton order, the same
/// points the whole sampling has there, whoever samples it.
std::vector<Vec3d> poissonDisk(const SetRegion& shape, double r, unsigned seed, SamplePart part = {});

/// The shape's volume [m^3].
double shapeVolume(const SetRegion& shape);

/// Minimum distance used for a target density of n points per unit volume: the tiled growth fills space
/// at about 1 / (kPoissonPacking r^3) points per volume (measured here: 1.82-1.83 in boxes and balls of
/// 4e4 to 3e5 points with 30 attempts; one growth from a single seed gave 1.80-1.82).
inline constexpr double kPoissonPacking = 1.82;

}  // namespace mpm
