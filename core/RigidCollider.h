#pragma once
// A rigid collider: a geometry in its rest placement, a motion (core/Motion.h) that poses it at each
// substep's time, and whether material stays outside it or inside (a tank, a glass, a drum). The geometry's
// distance and normal are called inline for every node of a leaf and every particle of a leaf near it, with one
// virtual call per leaf. A geometry has this shape (AnalyticGeometry below and core/LevelSetGeometry.h):
// @code
// struct Geometry {
//     struct Context { ... };                 // per task: an accessor, a cache; empty for analytic shapes
//     Context context() const;
//     void prepare(double t);                  // before a substep's passes, serially (load what time t needs)
//     double phi(const Vec3d& rest, double t, Context&) const;        // signed distance, > 0 outside
//     void phiNormal(const Vec3d& rest, double t, Context&, double& phi, Vec3d& n) const;  // and the unit normal
//     Vec3d surfaceVelocity(const Vec3d& rest, double t, Context&) const;  // of a deforming surface, rest frame
//     bool far(const Vec3d& rest, Context&) const;  // sure to be farther than colliderReach from the surface
//     double thinnest() const;                 // thinnest feature it resolves [m]; particles crossing less than
//                                              // half of it per substep need no swept test (0: never)
//     static constexpr bool kDeforming;        // whether surfaceVelocity can be nonzero
//     static constexpr const char* kName;
// };
// @endcode
#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "core/Collider.h"
#include "core/Motion.h"
#include "core/Species.h"  // ParticleArrays, which the particle pass reads and writes

namespace mpm {

template <class Shape>
struct AnalyticGeometry {
    Shape shape;
    struct Context {};
    static constexpr const char* kName = Shape::kType;
    static constexpr bool kDeforming = false;
    Context context() const { return {}; }
    void prepare(double) {}
    double phi(const Vec3d& x, double, Context&) const { return shape.signedDistance(x); }
    void phiNormal(const Vec3d& x, double, Context&, double& phi, Vec3d& n) const {
        phi = shape.signedDistance(x);
        n = shape.normalAt(x);
    }
    Vec3d surfaceVelocity(const Vec3d&, double, Context&) const { return Vec3d::Zero(); }
    bool far(const Vec3d&, Context&) const { return false; }  // the distance itself decides
    double thinnest() const { return 0.0; }
};

template <class Geometry>
class RigidCollider final : public Collider {
public:
    RigidCollider(Geometry geometry, Boundary b, float friction, Motion motion = Motion(), bool inside = false)
        : Collider(b, friction), geometry_(std::move(geometry)), motion_(std::move(motion)), sign_(inside ? -1.0 : 1.0) {}

    const Geometry& geometry() const { return geometry_; }
    bool moving() const override { return motion_.moving() || Geometry::kDeforming; }
    bool dynamic() const override { return motion_.dynamic(); }
    void prepare(double t) override { geometry_.prepare(t); }

    double signedDistance(const Vec3d& x, double t) const override {
        typename Geometry::Context c = geometry_.context();
        return sign_ * geometry_.phi(motion_.at(t).toRest(x), t, c);
    }
    Vec3d normal(const Vec3d& x, double t) const override {
        typename Geometry::Context c = geometry_.context();
        const Pose pose = motion_.at(t);
        double phi;
        Vec3d n;
        geometry_.phiNormal(pose.toRest(x), t, c, phi, n);
        return sign_ * (pose.R * n);
    }
    Vec3d velocity(const Vec3d& x, double t) const override {
        typename Geometry::Context c = geometry_.context();
        const Pose pose = motion_.at(t);
        return motion_.velocityAt(x, pose, motion_.ratesAt(t)) + pose.R * geometry_.surfaceVelocity(pose.toRest(x), t, c);
    }
    std::string describe() const override {
        std::ostringstream s;
        s << Geometry::kName << (sign_ < 0 ? " (inside)" : "") << " " << boundaryName(boundary()) << " friction " << friction()
          << (moving() ? " moving" : "");
        return s.str();
    }

    std::unique_ptr<ColliderContext> makeContext() const override { return std::make_unique<Context>(geometry_); }

    ColliderExchange applyToLeaf(const LeafView& leaf, const NodeBox& box, double dx, double t, ColliderContext* context,
                                 const SurfaceContact& surface) const override {
        ColliderExchange out;
        if (box.empty()) return out;
        typename Geometry::Context& c = static_cast<Context*>(context)->geometry;
        Frame f;
        if (!frameNear(leaf.origin, dx, t, c, nodeReach(dx), f)) return out;
        const bool still = f.still;
        // The normal condition node by node; Coulomb friction after, patch by patch (FrictionPatches).
        struct Pressed {
            int node;
            Vec3f vc, vt;
        };
        Pressed pressed[kLeafNodes];
        int count = 0;
        FrictionPatches patches;
        const bool body = motion_.dynamic();
        const Vec3d centre = motion_.momentCentre();
        // What the node gained: a dynamic body loses it; a prescribed motion did J . v_c of work (what the node
        // gains less what the inelastic contact dissipates), counted as external.
        const auto gave = [&](int n, const Vec3d& x, const Vec3f& dv, const Vec3f& vc) {
            if (body) {
                const Vec3d dp = double(leaf.mass[n]) * dv.template cast<double>();
                out.impulse += dp;
                out.angular += (x - centre).cross(dp);
            } else if (!still) {
                out.work += double(leaf.mass[n]) * dv.template cast<double>().dot(vc.template cast<double>());
            }
        };
        box.forEach([&](int n) {
            const float m = leaf.mass[n];
            if (m == 0.0f) return;
            const Vec3d x = (leaf.origin + leafLocal(n)).cast<double>() * dx;
            Vec3d rest = f.still ? x : f.pose.toRest(x);
            // Most nodes near a wall lie outside it: the normal (dearer for a level set) only where the wall acts.
            if (!acts(onSurface(sign_ * geometry_.phi(rest, t, c), dx), dx, still)) return;
            Vec3d normal;
            double phi;
            nodeDistance(x, f, t, dx, c, rest, phi, normal);
            // A `separate` wall is unilateral contact: it acts once the material's surface has reached it.
            if (boundary() == Boundary::Separate && !surface.touches(m, phi / dx)) return;
            const Vec3f nWorld = normal.template cast<float>();
            const Vec3f vc =
                still ? Vec3f(Vec3f::Zero()) : Vec3f(velocityAt(x, rest, f.pose, f.rates, t, c).template cast<float>());
            Eigen::Map<Vec3f> v(leaf.momentum + 3 * n);
            const Vec3f before = v;
            if (boundary() == Boundary::Sticky) {
                // In front of the wall the row holds material glued to it (at rest on it or pulled from it), not
                // material still arriving: that one the wall meets where it did before.
                if (phi > 0.0 && (v - vc).dot(nWorld) < 0.0f) return;
                v = vc;
            } else {
                const Vec3f rel = v - vc;
                const float vn = rel.dot(nWorld);
                // Leaving the object: `separate` lets the node go, and so does a wall with friction in every mode;
                // a frictionless `slip` wall holds it on the surface. Held in tension under friction, the back of a
                // body sliding on a slip floor pitched it ever harder onto its front (docs/method.md, Friction).
                if (vn >= 0.0f && (boundary() == Boundary::Separate || friction() > 0.0f)) return;
                const Vec3f vt = rel - vn * nWorld;
                v = vc + vt;
                patches.addNormal(n, m, vn);
                if (vn < 0.0f && friction() > 0.0f) {
                    patches.addPressed(n, m, vt);
                    pressed[count++] = {n, vc, vt};
                }
            }
            gave(n, x, v - before, vc);
        });
        for (int k = 0; k < count; ++k) {
            const Pressed& p = pressed[k];
            const float keep = patches.keep(p.node, friction());
            Eigen::Map<Vec3f> v(leaf.momentum + 3 * p.node);
            v = p.vc + keep * p.vt;
            gave(p.node, (leaf.origin + leafLocal(p.node)).template cast<double>() * dx, (keep - 1.0f) * p.vt, p.vc);
        }
        return out;
    }

    void wallNodesOfLeaf(const LeafView& leaf, const NodeBox& box, double dx, double t, double reach, ColliderContext* context,
                         std::vector<WallNode>& out) const override {
        if (box.empty()) return;
        typename Geometry::Context& c = static_cast<Context*>(context)->geometry;
        Frame f;
        if (!frameNear(leaf.origin, dx, t, c, nodeReach(dx) + reach, f)) return;
        constexpr double kOnNode = 1e-6;  // [cells]: an image this close to a node is that node
        const double invDx = 1.0 / dx;
        box.forEach([&](int n) {
            if (leaf.mass[n] == 0.0f) return;
            const Vec3d x = (leaf.origin + leafLocal(n)).cast<double>() * dx;
            Vec3d rest, normal;
            double phi;
            nodeDistance(x, f, t, dx, c, rest, phi, normal);
            if (phi == 0.0 || std::abs(phi) > reach) return;
            const Vec3d image = (x - 2.0 * phi * normal) * invDx;
            const Vec3i node = image.array().round().template cast<int>();
            if ((image - node.template cast<double>()).cwiseAbs().maxCoeff() > kOnNode) return;
            const Vec3d surface = x - phi * normal;
            const Vec3f vc =
                f.still ? Vec3f(Vec3f::Zero())
                        : Vec3f(velocityAt(surface, f.pose.toRest(surface), f.pose, f.rates, t, c).template cast<float>());
            out.push_back({n, node, phi, normal.template cast<float>(), vc});
        });
    }

    ProjectionResult projectParticles(ParticleArrays& P, uint32_t begin, uint32_t end, const Vec3i& leafOrigin, double dx,
                                      double t, float dt, const Vec3d& gravity, ColliderContext* context) const override {
        ProjectionResult out;
        if (begin == end) return out;
        typename Geometry::Context& c = static_cast<Context*>(context)->geometry;
        // The particles of a leaf lie within its base nodes' box grown by the stencil and a substep's travel.
        Frame f;
        if (!frameNear(leafOrigin, dx, t, c, colliderReach(dx), f)) return out;
        const Pose& pose = f.pose;
        const Motion::Rates& rates = f.rates;
        const bool still = f.still;
        const double thinnest = geometry_.thinnest();
        const bool body = motion_.dynamic();
        const Vec3d centre = motion_.momentCentre();
        for (uint32_t p = begin; p < end; ++p) {
            Vec3d& x = P.x[p];
            Vec3f& v = P.v[p];
            const Vec3d rest = still ? x : pose.toRest(x);
            double phi = sign_ * geometry_.phi(rest, t, c);
            Vec3d at = x;  // where the particle is found inside, if it is
            // A wall thinner than this substep's travel could be crossed in one step: look along the path.
            const double travel = double(dt) * double(v.norm());
            if (phi > 0.0 && thinnest > 0.0 && travel > 0.5 * thinnest) {
                const int samples = int(std::ceil(travel / (0.5 * thinnest)));
                const Vec3d from = x - double(dt) * v.cast<double>();
                for (int s = 1; s < samples && phi > 0.0; ++s) {
                    at = from + (double(s) / samples) * (x - from);
                    phi = sign_ * geometry_.phi(still ? at : pose.toRest(at), t, c);
                }
            }
            if (phi >= 0.0) continue;
            // Back to the surface along the normal, and the boundary condition on the velocity.
            double phiAt;
            Vec3d n;
            geometry_.phiNormal(still ? at : pose.toRest(at), t, c, phiAt, n);
            n = sign_ * (still ? n : Vec3d(pose.R * n));
            const double len = n.norm();
            if (!(len > 0.0)) continue;
            n /= len;
            const Vec3d moved = at - (sign_ * phiAt) * n;
            const Vec3f vc = still ? Vec3f(Vec3f::Zero())
                                   : Vec3f(velocityAt(moved, pose.toRest(moved), pose, rates, t, c).template cast<float>());
            const Vec3f before = v;
            const Vec3f rel = v - vc;
            if (rel.dot(n.cast<float>()) < 0.0f || boundary() == Boundary::Sticky)
                v = respond(v, n.cast<float>(), vc, boundary(), friction());
            if (body) {
                // The body takes what the particle gained: momentum m dv, and angular momentum, in which moving it out
                // counts too (r x m v before and after).
                const double m = double(P.mass[p]);
                out.impulse += m * (v - before).template cast<double>();
                out.angular += (moved - centre).cross(m * v.template cast<double>()) -
                               (x - centre).cross(m * before.template cast<double>());
            } else if (!still) {
                // As on the nodes, J . v_c; and moving the particle out against gravity is work too.
                const double impulse = double(P.mass[p]) * (v - before).template cast<double>().dot(vc.template cast<double>());
                out.work += impulse - double(P.mass[p]) * gravity.dot(moved - x);
            }
            x = moved;
            out.maxSpeed = std::max(out.maxSpeed, v.norm());
            ++out.moved;
        }
        return out;
    }

private:
    /// The collider's pose and rates at one time, as a pass over one leaf needs them.
    struct Frame {
        Pose pose;
        Motion::Rates rates;
        bool still;
    };
    /// How far from a leaf's centre a node of it lies at most: half the leaf's diagonal.
    static double nodeReach(double dx) { return std::sqrt(3.0) * 0.5 * (kLeafDim - 1) * dx; }
    /// The frame at t; false when nothing within `reach` of the leaf's centre can touch the collider.
    bool frameNear(const Vec3i& origin, double dx, double t, typename Geometry::Context& c, double reach, Frame& f) const {
        f = Frame{motion_.at(t), motion_.ratesAt(t), !moving()};
        const Vec3d centre = (origin.cast<double>() + Vec3d::Constant(0.5 * (kLeafDim - 1))) * dx;
        return !skip(f.still ? centre : f.pose.toRest(centre), t, c, reach);
    }
    /// How far in front of a sticky wall its nodes are held [cells]. Material glued to a wall fills the cells up to
    /// it, so the row of nodes nearest the wall on the material's side follows the wall, whatever the wall's place on
    /// the grid. Held only behind the wall, a wall just past a row of nodes left the material to the next row, which
    /// its particles barely reach (3% of their weight): a jelly block hanging from a sticky ceiling 0.01 cell past a
    /// row fell off, and a moving grip let go of a bar once it had passed a row. Short of half a cell: a wall halfway
    /// between rows holds the row behind it, as mirror mode (wall_ghosts) expects there. Only material at rest on the
    /// wall or moving away from it is held there (applyToLeaf): arriving material is met where it was before.
    static constexpr double kStickyReachCells = 0.5 - 1e-6;  ///< the float rounding of a wall exactly halfway stays out
    /// Whether the wall acts on a node at signed distance phi (positive on the material's side). Only a still wall holds
    /// the row in front of it: a moving one changes rows as it travels, and holding rows in front of a turning drum's
    /// wall changed its sand's avalanche (a dynamic incline of 44-51 degrees in the last second, against 43-48), so
    /// moving walls keep to the rows behind them until the hold fades with the distance (docs/method.md, section 7).
    bool acts(double phi, double dx, bool still) const {
        return boundary() == Boundary::Sticky && still ? phi < kStickyReachCells * dx : phi <= 0.0;
    }
    /// A signed distance within kOnSurfaceCells of zero is zero: a node on the surface (a floor on the grid's lines)
    /// is on it whichever way its position rounds through a pose. Without this a platform moved by keyframes held
    /// its surface row of nodes in some substeps and not in others, as p(t) - R pivot rounded to +-1e-18 m.
    static double onSurface(double phi, double dx) {
        constexpr double kOnSurfaceCells = 1e-9;
        return std::abs(phi) <= kOnSurfaceCells * dx ? 0.0 : phi;
    }
    /// A node's rest-frame position, its signed distance (positive on the material's side) and the outward
    /// normal in world axes.
    void nodeDistance(const Vec3d& x, const Frame& f, double t, double dx, typename Geometry::Context& c, Vec3d& rest,
                      double& phi, Vec3d& normal) const {
        rest = f.still ? x : f.pose.toRest(x);
        geometry_.phiNormal(rest, t, c, phi, normal);
        phi = onSurface(sign_ * phi, dx);
        normal = f.still ? Vec3d(sign_ * normal) : Vec3d(sign_ * (f.pose.R * normal));
    }
    /// Whether nothing within `reach` of a leaf centre can touch the collider: phi is 1-Lipschitz, so a
    /// distance larger than the reach says so; and beyond a level set's band, its coarse mask does.
    bool skip(const Vec3d& centreRest, double t, typename Geometry::Context& c, double reach) const {
        const double phi = sign_ * geometry_.phi(centreRest, t, c);
        return phi > reach || (phi > 0.0 && geometry_.far(centreRest, c));
    }
    /// The collider's velocity at a world point: its rigid motion's plus its surface's own (a deforming one).
    Vec3d velocityAt(const Vec3d& x, const Vec3d& rest, const Pose& pose, const Motion::Rates& rates, double t,
                     typename Geometry::Context& c) const {
        Vec3d v = motion_.velocityAt(x, pose, rates);
        if constexpr (Geometry::kDeforming) v += pose.R * geometry_.surfaceVelocity(rest, t, c);
        return v;
    }
    struct Context final : ColliderContext {
        explicit Context(const Geometry& g) : geometry(g.context()) {}
        typename Geometry::Context geometry;
    };
    Geometry geometry_;
    Motion motion_;
    double sign_;
};

}  // namespace mpm
