#pragma once
// A deforming collider: one level set per frame of a file sequence (Houdini's wall_$F4.vdb: wall_0001.vdb,
// wall_0002.vdb, ...), interpolated linearly in time between the frames around each substep's time and held
// before the first and after the last. Its surface moves at the files' velocity grid when they have one, and
// otherwise at the speed the interpolation implies, v = -(dphi/dt) grad phi / |grad phi|^2 (the level set
// equation). Frames are read when a substep first needs them, and only two are kept.
#include <climits>
#include <cmath>
#include <functional>
#include <map>
#include <memory>

#include "core/LevelSet.h"

namespace mpm {

struct LevelSetFrame {
    std::shared_ptr<const LevelSet> phi;
    std::shared_ptr<const VectorField> velocity;  ///< may be empty
};

class LevelSetSequenceGeometry {
public:
    using Loader = std::function<LevelSetFrame(int frame)>;
    static constexpr const char* kName = "level set sequence";
    static constexpr bool kDeforming = true;

    /// Frames first .. last exist; frame f holds the surface at time f / fps.
    LevelSetSequenceGeometry(Loader load, int first, int last, double fps, double voxelSize)
        : cache_(std::make_shared<Cache>(Cache{std::move(load), first, last, fps, voxelSize, {}, INT_MIN})) {}

    struct Context {
        int frame = INT_MIN;  ///< the frames the samplers below are of: frame and frame + 1
        std::unique_ptr<LevelSet::Sampler> a, b;
        std::unique_ptr<VectorField::Sampler> va, vb;
    };
    Context context() const { return Context{}; }

    /// Reads the two frames around time t (serial: the passes then only read).
    void prepare(double t) {
        Cache& c = *cache_;
        const int k = frameBefore(t);
        std::map<int, LevelSetFrame> keep;
        for (int f : {k, std::min(k + 1, c.last)}) {
            const auto it = c.frames.find(f);
            keep[f] = it != c.frames.end() ? it->second : c.load(f);
        }
        c.frames = std::move(keep);
        c.current = k;
    }

    double phi(const Vec3d& x, double t, Context& c) const {
        refresh(c);
        const double s = fraction(t);
        return (1.0 - s) * c.a->phi(x) + s * c.b->phi(x);
    }
    void phiNormal(const Vec3d& x, double t, Context& c, double& phi, Vec3d& n) const {
        Vec3d g;
        gradient(x, t, c, phi, g);
        const double len = g.norm();
        n = len > 0.0 ? Vec3d(g / len) : Vec3d::Zero();
    }
    Vec3d surfaceVelocity(const Vec3d& x, double t, Context& c) const {
        refresh(c);
        const double s = fraction(t);
        if (c.va) return (1.0 - s) * c.va->value(x) + s * (c.vb ? c.vb->value(x) : c.va->value(x));
        // The level set equation dphi/dt + v . grad phi = 0, with v along the normal.
        double phiA, phiB;
        Vec3d ga, gb;
        c.a->phiAndGradient(x, phiA, ga);
        c.b->phiAndGradient(x, phiB, gb);
        const Vec3d g = (1.0 - s) * ga + s * gb;
        const double g2 = g.squaredNorm();
        const Cache& k = *cache_;
        const bool held = k.current + 1 > k.last || k.current < k.first;
        return g2 > 0.0 && !held ? Vec3d(-(phiB - phiA) * k.fps * g / g2) : Vec3d::Zero();
    }
    bool far(const Vec3d& x, Context& c) const {
        refresh(c);
        return c.a->far(x) && c.b->far(x);
    }
    double thinnest() const { return cache_->voxelSize; }

private:
    struct Cache {
        Loader load;
        int first, last;
        double fps, voxelSize;
        std::map<int, LevelSetFrame> frames;
        int current;
    };
    int frameBefore(double t) const {
        const Cache& c = *cache_;
        const double f = std::floor(t * c.fps);
        return f < c.first ? c.first : f > c.last ? c.last : int(f);
    }
    double fraction(double t) const {
        const Cache& c = *cache_;
        const double s = t * c.fps - c.current;
        return c.current >= c.last || s < 0.0 ? 0.0 : std::min(s, 1.0);
    }
    void refresh(Context& ctx) const {
        const Cache& c = *cache_;
        if (ctx.frame == c.current) return;
        const LevelSetFrame& a = c.frames.at(c.current);
        const LevelSetFrame& b = c.frames.at(std::min(c.current + 1, c.last));
        ctx.a = std::make_unique<LevelSet::Sampler>(*a.phi);
        ctx.b = std::make_unique<LevelSet::Sampler>(*b.phi);
        ctx.va = a.velocity ? std::make_unique<VectorField::Sampler>(*a.velocity) : nullptr;
        ctx.vb = b.velocity ? std::make_unique<VectorField::Sampler>(*b.velocity) : nullptr;
        ctx.frame = c.current;
    }
    void gradient(const Vec3d& x, double t, Context& c, double& phi, Vec3d& g) const {
        refresh(c);
        const double s = fraction(t);
        double pa, pb;
        Vec3d ga, gb;
        c.a->phiAndGradient(x, pa, ga);
        c.b->phiAndGradient(x, pb, gb);
        phi = (1.0 - s) * pa + s * pb;
        g = (1.0 - s) * ga + s * gb;
    }
    std::shared_ptr<Cache> cache_;
};

}  // namespace mpm
