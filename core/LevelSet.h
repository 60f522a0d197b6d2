#pragma once
// A narrow-band signed distance field held in an OpenVDB level set (from a mesh or a VDB file, io/LevelSets.h),
// sampled trilinearly. Beyond the band its value is +-background, so distances there are lower bounds.
// OpenVDB stays inside core/LevelSet.cpp: a Sampler is the per-task accessor a collider keeps.
#include <memory>

#include "base/Types.h"

namespace mpm {

class LevelSet {
public:
    struct Grid;  ///< the OpenVDB grid (core/LevelSetGrid.h)
    /// `reach` [m]: how far from the band a point may be and still need the field (a grid leaf's half
    /// diagonal and a stencil); farther points are told apart by one lookup (Sampler::far).
    LevelSet(std::shared_ptr<const Grid> grid, double reach);
    ~LevelSet();

    /// Cached tree access for one task; not shared between threads.
    class Sampler {
    public:
        explicit Sampler(const LevelSet& ls);
        ~Sampler();
        /// phi at a world point.
        double phi(const Vec3d& x);
        /// phi (trilinear) and its gradient (central differences at the voxel corners, blended trilinearly) at a
        /// world point.
        void phiAndGradient(const Vec3d& x, double& phi, Vec3d& gradient);
        /// True when x lies farther than `reach` from the band: phi there, and anywhere within reach of x, is
        /// +-background with the sign phi(x) has.
        bool far(const Vec3d& x);
        /// True when the world box [lo, hi] lies wholly outside the surface and away from the band (phi is
        /// +background at every point of it), so that no search in it can find an inside point. False where that
        /// is not so, and, to stay cheap, for a box over more than kMaxOutsideLeaves of the field's leaves.
        bool outside(const Vec3d& lo, const Vec3d& hi);

    private:
        struct Impl;
        std::unique_ptr<Impl> impl_;
    };

    double voxelSize() const { return voxel_; }
    double background() const { return background_; }
    /// World box of the active voxels (the band).
    void bounds(Vec3d& lo, Vec3d& hi) const {
        lo = lo_;
        hi = hi_;
    }
    /// World box of the voxel centres at or inside the surface (phi <= 0): its middle is the solid's centre,
    /// whatever band the field has on either side (an empty box, lo > hi, where nothing is inside). A field remade
    /// from another (io/LevelSets.h, vdbLevelSet) answers with the box of the one it was made from, so that a
    /// collider's centre does not move with the voxel it was remade at.
    void insideBounds(Vec3d& lo, Vec3d& hi) const;
    void keepInsideBounds(const Vec3d& lo, const Vec3d& hi) { insideLo_ = lo, insideHi_ = hi, insideKept_ = true; }
    const Grid& grid() const { return *grid_; }

private:
    struct Near;  ///< a coarse mask of the band, grown by the reach
    std::shared_ptr<const Grid> grid_;
    std::shared_ptr<const Near> near_;
    double voxel_ = 0.0, background_ = 0.0;
    Vec3d lo_ = Vec3d::Zero(), hi_ = Vec3d::Zero();
    bool insideKept_ = false;
    Vec3d insideLo_ = Vec3d::Zero(), insideHi_ = Vec3d::Zero();
};

/// A vector grid (a VDB `vel` grid), sampled trilinearly; zero outside its active voxels.
class VectorField {
public:
    struct Grid;  ///< the OpenVDB grid (core/LevelSetGrid.h)
    explicit VectorField(std::shared_ptr<const Grid> grid) : grid_(std::move(grid)) {}
    class Sampler {
    public:
        explicit Sampler(const VectorField& f);
        ~Sampler();
        Vec3d value(const Vec3d& x);

    private:
        struct Impl;
        std::unique_ptr<Impl> impl_;
    };
    const Grid& grid() const { return *grid_; }

private:
    std::shared_ptr<const Grid> grid_;
};

}  // namespace mpm
