#pragma once
// Rigid motion of a collider: where its geometry is at time t, and how fast each point of it moves. A pose
// maps the collider's rest placement (as the scene gives it) to the world, x = R x_rest + T. Two kinds:
//  - constant: a velocity v and an angular velocity w (rad/s) about a pivot,
//    x(t) = pivot + v t + Rot(w t) (x_rest - pivot);
//  - keyframes: at frame f_k the pivot is at position p_k and the body turned by rotation q_k,
//    x(f) = p(f) + R(f) (x_rest - pivot), p linear and R spherical linear (slerp) between keys, held before
//    the first key and after the last; frames may be fractional;
//  - dynamic: a rigid body the material moves (core/RigidBody.h); the simulation poses it before each substep's
//    collider passes, and the motion reads that pose whatever the time asked. An animated body follows a motion of
//    the kinds above until it is released (the frame says when), as a prescribed collider, and is a body after.
// The velocity of a point x of the collider is v_c(x) = dT/dt + w x (x - T') with w the angular velocity,
// which is what sticky, slip, separate and friction act relative to.
#include <memory>
#include <vector>

#include "base/Types.h"

namespace mpm {

struct Pose {
    Mat3d R = Mat3d::Identity();
    Vec3d T = Vec3d::Zero();
    Vec3d toWorld(const Vec3d& rest) const { return R * rest + T; }
    Vec3d toRest(const Vec3d& world) const { return R.transpose() * (world - T); }
};

/// A rotation as a scene gives it: an axis (any length but zero) and an angle in degrees.
Mat3d rotationFromAxisDegrees(const Vec3d& axis, double degrees);

/// A dynamic body's pose and velocity for the collider passes under way: its centre of mass moves at `linear`
/// and it turns at `angular` about it.
struct BodyFrame {
    Pose pose;
    Vec3d centre = Vec3d::Zero();  ///< of mass, in the world
    Vec3d linear = Vec3d::Zero(), angular = Vec3d::Zero();
    bool released = true;  ///< false while an animated body follows its animation
};

class Motion {
public:
    struct Key {
        double frame = 0.0;
        Vec3d position = Vec3d::Zero();  ///< of the pivot
        Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
    };

    /// No motion.
    Motion() = default;
    static Motion constant(const Vec3d& velocity, const Vec3d& angularVelocity, const Vec3d& pivot);
    /// Keys sorted by frame (at least one); fps turns frames into time.
    static Motion keyframes(std::vector<Key> keys, const Vec3d& pivot, double fps);
    /// A body the material moves: the pose is whatever `frame` holds when asked; with an `animation`, that motion's
    /// pose while the frame is not released (the body then acts as a prescribed collider: not dynamic).
    static Motion dynamic(std::shared_ptr<const BodyFrame> frame, std::shared_ptr<const Motion> animation = nullptr);

    bool dynamic() const { return kind_ == Kind::Dynamic && !animated(); }
    /// The point a dynamic body's angular impulse is taken about: its centre of mass (the origin for the others).
    Vec3d momentCentre() const { return frame_ ? frame_->centre : Vec3d::Zero(); }

    bool moving() const { return kind_ != Kind::None; }
    Pose at(double t) const;
    /// Linear velocity of the pose's origin and angular velocity at time t: v_c(x) = linear + w x (x - T).
    struct Rates {
        Vec3d linear = Vec3d::Zero(), angular = Vec3d::Zero();
    };
    /// `before`: the rates just before t (where keyframes change them at t: a body released at its last key leaves
    /// at the velocity that brought it there).
    Rates ratesAt(double t, bool before = false) const;
    Vec3d velocityAt(const Vec3d& x, const Pose& pose, const Rates& r) const { return r.linear + r.angular.cross(x - pose.T); }

private:
    bool animated() const { return animation_ && !frame_->released; }

    enum class Kind { None, Constant, Keyframes, Dynamic } kind_ = Kind::None;
    Vec3d velocity_ = Vec3d::Zero(), angular_ = Vec3d::Zero(), pivot_ = Vec3d::Zero();
    std::vector<Key> keys_;
    double fps_ = 24.0;
    std::shared_ptr<const BodyFrame> frame_;
    std::shared_ptr<const Motion> animation_;
};

}  // namespace mpm
