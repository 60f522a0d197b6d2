#pragma once
// A collider geometry sampled from a level set (a mesh's distance field or a VDB level set): the form
// core/RigidCollider.h asks for, with the per-task tree accessor as its context.
#include <memory>

#include "core/LevelSet.h"

namespace mpm {

struct LevelSetGeometry {
    std::shared_ptr<const LevelSet> levelSet;
    static constexpr const char* kName = "level set";
    static constexpr bool kDeforming = false;

    struct Context {
        std::unique_ptr<LevelSet::Sampler> sampler;
    };
    Context context() const { return Context{std::make_unique<LevelSet::Sampler>(*levelSet)}; }
    void prepare(double) {}
    double phi(const Vec3d& x, double, Context& c) const { return c.sampler->phi(x); }
    Vec3d surfaceVelocity(const Vec3d&, double, Context&) const { return Vec3d::Zero(); }
    void phiNormal(const Vec3d& x, double, Context& c, double& phi, Vec3d& n) const {
        Vec3d g;
        c.sampler->phiAndGradient(x, phi, g);
        const double len = g.norm();
        n = len > 0.0 ? Vec3d(g / len) : Vec3d::Zero();  // beyond the band the field is flat: no normal
    }
    bool far(const Vec3d& x, Context& c) const { return c.sampler->far(x); }
    /// A wall must be a couple of voxels thick to show in the field; the swept test samples finer than that.
    double thinnest() const { return levelSet->voxelSize(); }
};

}  // namespace mpm
