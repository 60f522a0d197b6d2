#pragma once
// Rigid, one-way colliders applied to grid nodes after the grid update (thesis section 5; Stomakhin et al.
// 2013, sec. 8). A collider is a signed distance function of position and time, phi > 0 outside, with its
// normal and surface velocity. The grid update hands every collider each leaf with a context of its own per
// task, so that a collider that samples a tree (a level set) can keep an accessor there.
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "base/Types.h"
#include "core/Settings.h"
#include "sparse/LeafGeometry.h"

namespace mpm {

struct ParticleArrays;

/// How far from a grid leaf's centre a collider can still matter to the leaf's nodes or particles [cells]:
/// half the diagonal of the leaf grown by the stencil and a substep's travel (3 cells each side).
inline double colliderReach(double dx) {
    constexpr double kMarginCells = 3.0;
    return 0.5 * std::sqrt(3.0) * (kLeafDim - 1 + 2.0 * kMarginCells) * dx;
}

const char* boundaryName(Boundary b);

/// Coulomb friction over contact patches: the contact nodes of a leaf are grouped into cubes of
/// kPatchDim^3 nodes, and each patch sticks while the tangential momentum its pressed nodes carry relative to
/// the collider, |T| = |sum m v_t|, is at most mu N, N = sum -m v_n its net normal impulse; otherwise every
/// pressed node's v_t shrinks by the factor that makes the patch's friction impulse mu N. Node by node (a patch
/// of one) the law misfires on a grid: the kernel spreads one traction over nodes at several depths, and the
/// shares of tangential and normal impulse differ node by node (a staircase of nodes under a tilted wall, the
/// little mass of nodes deep in it), so that static contact creeps. Only pressed nodes enter: a wall with friction
/// lets a node moving away go in every mode (RigidCollider::applyToLeaf).
class FrictionPatches {
public:
    /// A patch is the whole leaf: measured on the friction cases of the validation report, leaf patches pass 13
    /// of 20, patches of 4^3 nodes 12, single nodes 6 (docs/validation/report.md).
    static constexpr int kPatchLog2 = 3;
    static constexpr int kPatchDim = 1 << kPatchLog2;
    static constexpr int kPerAxis = kLeafDim / kPatchDim;
    static constexpr int kPatches = kPerAxis * kPerAxis * kPerAxis;

    /// A node whose normal velocity vn (relative to the collider, along the outward normal) the wall removed:
    /// -m vn enters its patch's normal impulse (negative for a node held on the wall as it moves away).
    void addNormal(int node, float m, float vn) { patch(node).normal -= double(m) * double(vn); }
    /// A pressed node (vn < 0) with tangential velocity vt relative to the collider: it takes friction.
    void addPressed(int node, float m, const Vec3f& vt) { patch(node).tangential += double(m) * vt.cast<double>(); }
    /// The factor of a pressed node's vt that friction leaves: 0 while its patch sticks.
    float keep(int node, float mu) const {
        const Patch& p = patches_[index(node)];
        const double budget = double(mu) * std::max(p.normal, 0.0), t = p.tangential.norm();
        return t <= budget ? 0.0f : float(1.0 - budget / t);
    }

private:
    struct Patch {
        double normal = 0.0;
        Vec3d tangential = Vec3d::Zero();
    };
    static int index(int node) {
        const Vec3i l = leafLocal(node);
        return ((l[0] >> kPatchLog2) * kPerAxis + (l[1] >> kPatchLog2)) * kPerAxis + (l[2] >> kPatchLog2);
    }
    Patch& patch(int node) { return patches_[index(node)]; }
    Patch patches_[kPatches];
};

/// Where a `separate` wall acts (simulation.wall_contact). With "stencil", on every node inside the collider that
/// has mass, so the wall reaches material up to the stencil's half width (1.5 cells for the quadratic kernel)
/// before its surface arrives (the default). With "surface", a node inside the collider acts only once the
/// material has reached the collider's surface there: a node of mass m is covered to the share f = m / (rho dx^3) of its support,
/// which a flat material surface s cells beyond the node gives when f = F(s) (F the kernel's covered fraction); the material
/// touches the wall at the node when s + phi / dx <= 0.
///
/// rho is the rest density of the material at the node: one value when every body has the same, else that of the
/// particles binned in the node's leaf (their stencils' base nodes in it), so that a body of another density
/// elsewhere changes nothing (docs/method.md, section 7).
struct SurfaceContact {
    float cellMass = 0.0f;                ///< rest density times dx^3; 0: the wall acts wherever the stencil reaches
    const float* leafCellMass = nullptr;  ///< per leaf of the field, where its bodies' densities differ
    double (*covered)(double) = nullptr;  ///< the kernel's covered fraction F(s), decreasing from 1 to 0
    /// The contact test for the nodes of leaf l.
    SurfaceContact ofLeaf(std::size_t l) const {
        SurfaceContact s = *this;
        if (leafCellMass) s.cellMass = leafCellMass[l], s.leafCellMass = nullptr;
        return s;
    }
    /// Whether a node of mass m at signed distance phi (cells) has the material at or past the wall.
    bool touches(float m, double phiCells) const {
        if (cellMass <= 0.0f) return true;
        const double f = double(m) / double(cellMass);
        // F is monotone: the surface lies beyond -phi (at or past the wall) iff F(-phi) <= f. Measured: allowing
        // the surface a quarter cell short of the wall held a resting block better but brought early contact back.
        return covered(-phiCells) <= f;
    }
};

/// What one task of the grid update keeps for one collider between the leaves it visits (an accessor, a
/// cache); analytic colliders keep nothing.
struct ColliderContext {
    virtual ~ColliderContext() = default;
};

/// What a collider's pass over one leaf gave the material: the work a prescribed motion did on it, or, for a
/// dynamic body (core/RigidBody.h), the impulse and the angular impulse about the body's centre of mass.
struct ColliderExchange {
    double work = 0.0;              ///< [J] impulse times the collider's velocity (prescribed motion only)
    Vec3d impulse = Vec3d::Zero();  ///< [N s] sum of m dv (dynamic bodies only)
    Vec3d angular = Vec3d::Zero();  ///< [N m s] sum of (x - centre) x m dv (dynamic bodies only)
};

class Collider {
public:
    Collider(Boundary boundary, float friction) : boundary_(boundary), friction_(friction) {}
    virtual ~Collider() = default;

    virtual double signedDistance(const Vec3d& x, double t) const = 0;
    /// Outward unit normal (grad phi) at x and time t.
    virtual Vec3d normal(const Vec3d& x, double t) const = 0;
    /// Velocity of the collider surface at x and time t (zero for static colliders).
    virtual Vec3d velocity(const Vec3d& x, double t) const = 0;
    virtual std::string describe() const = 0;

    /// Whether the collider moves (then it does work on the material, counted by the energy check).
    virtual bool moving() const { return false; }
    /// Whether it is a rigid body the material moves: its passes report the momentum they exchange instead of work.
    virtual bool dynamic() const { return false; }
    /// Called once before each substep's collider passes, serially, with their time: a collider that changes
    /// over time (a sequence of level sets) loads what that time needs here.
    virtual void prepare(double /*t*/) {}
    /// A context for one task; the default is none.
    virtual std::unique_ptr<ColliderContext> makeContext() const { return nullptr; }
    /// Applies the boundary condition at time t to every node in `box` of a leaf with phi <= 0 and nonzero mass
    /// (for a `separate` wall, only where `surface` says the material has reached it), with Coulomb friction per
    /// contact patch (FrictionPatches). A leaf whose centre lies farther from the surface than its half diagonal is skipped (phi
    /// is 1-Lipschitz). Returns what it gave the nodes: a moving collider's work, a dynamic body's impulses.
    virtual ColliderExchange applyToLeaf(const LeafView& leaf, const NodeBox& box, double dx, double t, ColliderContext* context,
                                         const SurfaceContact& surface) const = 0;

    /// A node with mass near the surface whose mirror image across it, x - 2 phi n, is a grid node (a wall on the
    /// grid's lines or halfway between), for the mirror passes (simulation.wall_ghosts = "mirror").
    struct WallNode {
        int node;        ///< in its leaf
        Vec3i image;     ///< the node its mirror image falls on
        double phi;      ///< [m] the node's signed distance: < 0 inside the collider (a ghost), > 0 in front of it
        Vec3f normal;    ///< outward, at the node
        Vec3f velocity;  ///< the collider's, at the surface
    };
    /// Appends a leaf's wall nodes at time t within `reach` [m] of the surface on either side (none for a leaf far
    /// from it).
    virtual void wallNodesOfLeaf(const LeafView& leaf, const NodeBox& box, double dx, double t, double reach,
                                 ColliderContext* context, std::vector<WallNode>& out) const = 0;

    /// What the particle pass did to one leaf's particles.
    struct ProjectionResult {
        double work = 0.0;  ///< work a moving collider did (impulse times its velocity, and lifting against gravity)
        Vec3d impulse = Vec3d::Zero(), angular = Vec3d::Zero();  ///< a dynamic body's, as ColliderExchange's
        float maxSpeed = 0.0f;                                   ///< of the particles it moved
        std::size_t moved = 0;
    };
    /// After advection: particles [begin, end) of a leaf found inside the collider at time t (or, for a wall
    /// thinner than this step's travel, on the way through it) are moved back to its surface along the normal,
    /// and their velocity gets the boundary condition. This keeps material out of walls thinner than a cell,
    /// which conditions on grid nodes alone let it through.
    virtual ProjectionResult projectParticles(ParticleArrays& particles, uint32_t begin, uint32_t end, const Vec3i& leafOrigin,
                                              double dx, double t, float dt, const Vec3d& gravity,
                                              ColliderContext* context) const = 0;

    Boundary boundary() const { return boundary_; }
    float friction() const { return friction_; }

    /// The node response: v is the node velocity before the collision, n the outward normal, vc the
    /// collider velocity. Coulomb friction scales with the normal velocity change |v_after - v|.
    static Vec3f respond(const Vec3f& v, const Vec3f& n, const Vec3f& vc, Boundary boundary, float friction);

private:
    Boundary boundary_;
    float friction_;
};

}  // namespace mpm
