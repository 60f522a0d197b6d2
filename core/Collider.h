#pragma once
// Rigid, one-way colliders applied to grid nodes after the grid update (thesis section 5; Stomakhin et al.
// 2013, sec. 8). A collider is a signed distance function, phi > 0 outside; planes and spheres ship here,
// and level-set or moving colliders only need to implement signedDistance/normal/velocity.
#include <memory>
#include <string>

#include "core/Types.h"

namespace mpm {

struct LeafView;
struct NodeBox;

enum class Boundary {
    Sticky,    ///< node velocity becomes the collider's
    Slip,      ///< the normal component is removed, in both directions
    Separate,  ///< the normal component is removed only while the node moves into the object
};

const char* boundaryName(Boundary b);

class Collider {
public:
    Collider(Boundary boundary, float friction) : boundary_(boundary), friction_(friction) {}
    virtual ~Collider() = default;

    virtual double signedDistance(const Vec3d& x) const = 0;
    /// Outward unit normal (grad phi) at x.
    virtual Vec3d normal(const Vec3d& x) const = 0;
    /// Velocity of the collider surface at x and time t (zero for static colliders).
    virtual Vec3d velocity(const Vec3d& /*x*/, double /*t*/) const { return Vec3d::Zero(); }
    virtual std::string describe() const = 0;

    Boundary boundary() const { return boundary_; }
    float friction() const { return friction_; }

    /// Applies the boundary condition to every node in the box of a leaf with phi <= 0 and nonzero mass. A leaf whose
    /// centre lies farther from the surface than its half diagonal is skipped (phi is 1-Lipschitz).
    void applyToLeaf(const LeafView& leaf, const NodeBox& box, double dx, double time) const;

    /// The node response: v is the node velocity before the collision, n the outward normal, vc the
    /// collider velocity. Coulomb friction scales with the normal velocity change |v_after - v|.
    static Vec3f respond(const Vec3f& v, const Vec3f& n, const Vec3f& vc, Boundary boundary, float friction);

private:
    Boundary boundary_;
    float friction_;
};

/// Half space below a plane: phi = n . (x - p).
class PlaneCollider final : public Collider {
public:
    PlaneCollider(const Vec3d& point, const Vec3d& normal, Boundary b, float friction);
    double signedDistance(const Vec3d& x) const override { return normal_.dot(x - point_); }
    Vec3d normal(const Vec3d&) const override { return normal_; }
    std::string describe() const override;

private:
    Vec3d point_, normal_;
};

/// Solid ball: phi = |x - c| - r.
class SphereCollider final : public Collider {
public:
    SphereCollider(const Vec3d& centre, double radius, Boundary b, float friction);
    double signedDistance(const Vec3d& x) const override { return (x - centre_).norm() - radius_; }
    Vec3d normal(const Vec3d& x) const override;
    std::string describe() const override;

private:
    Vec3d centre_;
    double radius_;
};

}  // namespace mpm
