#pragma once
// Rigid bodies the material moves (two-way coupling): a collider with mass and inertia whose pose is integrated
// from gravity and the impulses it exchanges with the material each substep. The exchange is the collider passes'
// own: what the boundary condition and friction change in the nodes' momentum (m dv), and what the particle pass
// changes in the particles', is what the body loses, so material and bodies together keep their momentum and
// angular momentum to round-off. Partitioned coupling, symplectic Euler for the body (position first):
//   move     x' = x + dt v,  q' = exp(dt w / 2) q;
//   the collider passes run with the body at (x', q') moving at (v, w), the motion that takes it there, so that the
//   velocity the wall gives the nodes is the wall's true displacement over the step; they sum the material's
//   impulse J and its angular impulse L about x';
//   then     v' = v + dt g - J / M,  w' = I'^-1 (I w - L),  with I = R I_rest R^T at q and I' at q'
//   (the angular momentum a free body keeps, so Euler's gyroscopic term is exact).
// Giving the nodes any other velocity than the wall's displacement pushes the material under a resting body a little
// every step, which the particle pass then squeezes. The scheme keeps E - dt M g . v / 2 in free flight (its
// modified energy) where E = 1/2 M v^2 + 1/2 w . I w - M g . x gains M g^2 dt^2 / 2 a step: booked with E alone, a
// body falling in air tripped the energy check where the material was light.
// An animated body (a motion and a release time) follows its motion until then as a prescribed collider (its work on
// the material booked as any moving collider's; other bodies touch it as a fixed collider), then is a body from the
// pose, velocity and spin the motion had. Locked axes (world axes) keep their velocity component at zero. Against the fixed
// colliders (those the scene moves, or not at all) a body touches at sample points of its surface: contact with Newton's
// restitution (none by default), Coulomb friction and a rolling-resistance couple (none by default) by sequential impulses
// (projected Gauss-Seidel over the contacts, a fixed number of sweeps in a fixed order, with speculative contacts for points a
// step could carry in: Catto 2006, "Fast and Simple Physics using Sequential Impulses"); a contact bounces when the step closes
// it at more than one step's gravity (slower, it rests), from where the step began (up to one step's travel early: the limit of
// speculative contacts); then the body is moved out along the contacts' normals. Two bodies touch the same way, each one's
// samples against the other's shape, with equal and opposite impulses (momentum kept) and the push out shared by their inverse
// masses; the pairs are solved in collider order after the contacts with the fixed colliders.
#include <array>
#include <cmath>
#include <memory>
#include <vector>

#include "base/Types.h"
#include "core/ExactSum.h"
#include "core/Motion.h"

namespace mpm {

class Collider;

/// A collider a body touches that the body cannot move: a fixed one (still or moving as the scene says), or an
/// animated body while animated, with that body's restitution.
struct FixedCollider {
    const Collider* collider = nullptr;
    double restitution = 0.0;
};

/// Where a body is and how it moves: what a checkpoint stores of it.
struct RigidBodyState {
    Vec3d centre = Vec3d::Zero();                                     ///< of mass [m]
    Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< from the scene's placement
    Vec3d velocity = Vec3d::Zero();                                   ///< of the centre [m/s]
    Vec3d spin = Vec3d::Zero();                                       ///< angular velocity [rad/s], world axes

    static constexpr int kDoubles = 13;
    void write(double* out) const;
    void read(const double* in);
};

/// What does not change: mass, inertia, where the centre of mass sits in the scene's placement, and the locks.
struct RigidBodyModel {
    double mass = 0.0;                  ///< [kg]
    Mat3d inertia = Mat3d::Identity();  ///< about the centre of mass, in the scene's placement [kg m^2]
    Vec3d restCentre = Vec3d::Zero();   ///< centre of mass in the scene's placement [m]
    Vec3d moveFree = Vec3d::Ones();     ///< per world axis, 1 free or 0 locked
    Vec3d turnFree = Vec3d::Ones();
    std::vector<Vec3d> contactPoints;         ///< surface samples in the scene's placement (core/shapes/MassProperties.h)
    std::vector<double> contactRadii;         ///< per sample: the surface lies this far beyond it (a sphere's radius)
    double restitution = 0.0;                 ///< of its contacts with colliders and bodies: separating over approaching speed
    double rollingResistance = 0.0;           ///< couple against rolling over normal force times the centre's height
    std::shared_ptr<const Motion> animation;  ///< followed until `release`; none: the material moves it from the start
    double release = 0.0;                     ///< [s]

    /// Whether a step starting at time t follows the animation (the body is prescribed: the material does not move it).
    bool animatedAt(double t) const { return animation && t < release; }
    /// Where the animation has it at time t, moving at the animation's velocity and spin there (at the release, those
    /// just before it: what the body leaves with).
    RigidBodyState animated(double t) const;

    /// The body at rest where the scene places it.
    RigidBodyState initial(const Vec3d& velocity, const Vec3d& spin) const;
    /// Where the step's start velocities take it by the step's end (the velocities stay).
    RigidBodyState moved(const RigidBodyState& s, double dt) const;
    /// The velocities at the step's end of a body that started the step in `start` and has moved to `s`: gravity,
    /// and what the material took, J and, about the body's centre, L (the body loses both).
    void accelerate(const RigidBodyState& start, RigidBodyState& s, double dt, const Vec3d& gravity, const Vec3d& J,
                    const Vec3d& L) const;
    /// Contact with the fixed colliders at time t, at the state's pose, before a next step of about dt: the
    /// velocities change by the impulses of Coulomb contact (a point in a collider stops approaching it, one outside
    /// may close its gap in dt, no more; one met at more than one step's gravity bounces back at `restitution` times
    /// the speed it met it at, the step's gravity not counted; the larger of the two restitutions), and the body moves
    /// out of them. Returns the contacts; `work` receives the work the colliders' motion did on the body (each contact's
    /// impulse times the collider's velocity there: external, as a moving collider's on the material).
    int touch(RigidBodyState& s, const std::vector<FixedCollider>& fixed, double t, double dt, const Vec3d& gravity,
              double& work) const;
    /// The farthest a point of the body reaches from its centre of mass (contact samples with their radii).
    double extent() const;
    /// Kinetic plus gravitational energy (zero height at the origin, as the particles'), less dt M g . v / 2: the
    /// energy the scheme keeps in free flight over steps of dt.
    double energy(const RigidBodyState& s, const Vec3d& gravity, double dt) const;
    /// The pose and velocity the collider passes read.
    BodyFrame frame(const RigidBodyState& s) const;
    /// The fastest a point of the body moves: |v| + |w| times a bound on its reach from the centre of mass
    /// (sqrt(1.5 tr I / m): the half diagonal of a box, above a sphere's or a cylinder's reach).
    double fastestPoint(const RigidBodyState& s) const {
        return s.velocity.norm() + s.spin.norm() * std::sqrt(1.5 * inertia.trace() / mass);
    }
    /// The world inertia tensor at an orientation.
    Mat3d worldInertia(const Eigen::Quaterniond& q) const;
};

/// Contact between bodies a and b at time t, at their states' poses, before a next step of about dt: a's samples
/// against b's collider (its shape at b's pose) and b's against a's, with the larger of the two restitutions and
/// Coulomb friction (the smaller of the two colliders' coefficients; a sticky one counts as infinite), by sequential
/// impulses equal and opposite on the two; then they are moved apart along the contacts' normals in the ratio of
/// their inverse masses. The colliders must read the states' poses (their frames set from them). Returns the contacts.
int touchBodies(const RigidBodyModel& A, RigidBodyState& a, const Collider& colliderA, const RigidBodyModel& B, RigidBodyState& b,
                const Collider& colliderB, double t, double dt, const Vec3d& gravity);

/// The impulse and angular impulse a body's collider passes gave the material, summed exactly (core/ExactSum.h),
/// so that the body moves the same on any number of threads and ranks.
struct BodyImpulse {
    std::array<ExactSum, 6> sum;
    void add(const Vec3d& impulse, const Vec3d& angular) {
        for (int a = 0; a < 3; ++a) sum[std::size_t(a)] += impulse[a], sum[std::size_t(a + 3)] += angular[a];
    }
    BodyImpulse& operator+=(const BodyImpulse& o) {
        for (std::size_t k = 0; k < sum.size(); ++k) sum[k] += o.sum[k];
        return *this;
    }
    Vec3d impulse() const { return {sum[0].value(), sum[1].value(), sum[2].value()}; }
    Vec3d angular() const { return {sum[3].value(), sum[4].value(), sum[5].value()}; }
};

}  // namespace mpm
