#include "core/RigidBody.h"

#include <algorithm>
#include <limits>

#include "core/Collider.h"

namespace mpm {

void RigidBodyState::write(double* out) const {
    for (int a = 0; a < 3; ++a) out[a] = centre[a], out[7 + a] = velocity[a], out[10 + a] = spin[a];
    out[3] = orientation.w(), out[4] = orientation.x(), out[5] = orientation.y(), out[6] = orientation.z();
}

void RigidBodyState::read(const double* in) {
    for (int a = 0; a < 3; ++a) centre[a] = in[a], velocity[a] = in[7 + a], spin[a] = in[10 + a];
    orientation = Eigen::Quaterniond(in[3], in[4], in[5], in[6]);
}

RigidBodyState RigidBodyModel::initial(const Vec3d& velocity, const Vec3d& spin) const {
    RigidBodyState s;
    s.centre = restCentre;
    s.velocity = velocity.cwiseProduct(moveFree);
    s.spin = spin.cwiseProduct(turnFree);
    return s;
}

RigidBodyState RigidBodyModel::animated(double t) const {
    const Pose pose = animation->at(t);
    RigidBodyState s;
    s.centre = pose.toWorld(restCentre);
    s.orientation = Eigen::Quaterniond(pose.R).normalized();
    // The velocities at t, or just before the release where t is past it (the step that ends there may overshoot it).
    const double tv = std::min(t, release);
    const Pose at = tv == t ? pose : animation->at(tv);
    const Motion::Rates rates = animation->ratesAt(tv, true);
    s.velocity = animation->velocityAt(at.toWorld(restCentre), at, rates);
    s.spin = rates.angular;
    return s;
}

Mat3d RigidBodyModel::worldInertia(const Eigen::Quaterniond& q) const {
    const Mat3d R = q.toRotationMatrix();
    return R * inertia * R.transpose();
}

RigidBodyState RigidBodyModel::moved(const RigidBodyState& s, double dt) const {
    RigidBodyState p = s;
    p.centre = s.centre + dt * s.velocity;
    const double angle = s.spin.norm() * dt;
    if (angle > 0.0)
        p.orientation = (Eigen::Quaterniond(Eigen::AngleAxisd(angle, s.spin.normalized())) * s.orientation).normalized();
    return p;
}

void RigidBodyModel::accelerate(const RigidBodyState& start, RigidBodyState& s, double dt, const Vec3d& gravity, const Vec3d& J,
                                const Vec3d& L) const {
    s.velocity = (start.velocity + dt * gravity - J / mass).cwiseProduct(moveFree);
    // Angular momentum is what a free body keeps: I w at the step's start, less what the material took, turned
    // into the spin of the new orientation (Euler's equations, their gyroscopic term included, kept exactly).
    const Vec3d momentum = worldInertia(start.orientation) * start.spin - L;
    s.spin = worldInertia(s.orientation).ldlt().solve(momentum).cwiseProduct(turnFree);
}

namespace {

/// A contact point between body a and what it touches (body b, or a fixed collider).
struct Contact {
    Vec3d ra, rb;                      ///< from each centre to the contact point
    Vec3d n;                           ///< the normal, pointing from b (or the collider) to a
    Vec3d vc = Vec3d::Zero();          ///< a fixed collider's velocity at the point (zero between bodies)
    double depth;                      ///< < 0: a gap the next step may close, no more
    double mu;                         ///< Coulomb coefficient, infinite for a sticky collider
    double restitution = 0.0;          ///< separating over approaching speed
    double target = 0.0;               ///< the normal velocity the contact seeks: the gap's closing, or a bounce
    double normal = 0.0;               ///< accumulated normal impulse
    Vec3d tangential = Vec3d::Zero();  ///< accumulated friction impulse
};

/// One side of the contacts: its state and how an impulse changes its velocities (nothing, for a fixed collider).
struct Side {
    RigidBodyState& s;
    Vec3d invMass = Vec3d::Zero();  ///< per world axis; locked axes take no impulse
    Mat3d invI = Mat3d::Zero();
    Vec3d moveFree = Vec3d::Zero();

    Side(RigidBodyState& state, const RigidBodyModel& m) : s(state) {
        invMass = m.moveFree / m.mass;
        const Mat3d turn = m.turnFree.asDiagonal();
        invI = turn * m.worldInertia(s.orientation).inverse() * turn;
        moveFree = m.moveFree;
    }
    explicit Side(RigidBodyState& fixed) : s(fixed) {}
};

/// Sequential impulses on the contacts between a and b (Catto 2006), equal and opposite on the two; then a and b
/// are moved apart along the normals, by what is left of each contact's depth, in the ratio of their inverse
/// masses. A contact that closes within the step at more than `restingSpeed` bounces: it seeks a separating speed
/// its restitution times its approach (Newton's law of restitution), the approach without what the step's gravity
/// added to it (`stepGravity`, the change gravity made in the relative velocity). Position-first Euler brings a body
/// back to a height at g dt more than the speed it left at, so bouncing the approach with the step's gravity in it
/// keeps a resting body hopping: at e g dt / (1 - e), beyond any fixed threshold as e nears 1. Returns the work the
/// contacts' moving colliders did on a: each one's impulse times its velocity (zero between bodies). `rolling`: the
/// rolling resistance coefficient of the pair.
/// Sequential-impulse sweeps: at least kMinSweeps, then until the largest change of an impulse in a sweep is under
/// kConverged of the largest normal impulse, or kMaxSweeps. A faceted ball (r = 10 voxels) landing at 2.5 m/s kept
/// 1.1 rad/s of spin after 8 sweeps, 0.48 after 32, 0.06 after 128 and none after 256.
constexpr int kMinSweeps = 8, kMaxSweeps = 256;
constexpr double kConverged = 1e-6;
/// The widest patch of pressed points, over the lever, that rolls (takes the rolling-resistance couple): a ball's
/// point, a cylinder's line, a rounded rock's few points; a box's face is wider.
constexpr double kRollingPatch = 0.1;

double solveContacts(Side a, Side b, std::vector<Contact>& contacts, double dt, double restingSpeed, const Vec3d& stepGravity,
                     double rolling) {
    const auto push = [&](const Contact& c, const Vec3d& J) {
        a.s.velocity += a.invMass.cwiseProduct(J);
        a.s.spin += a.invI * c.ra.cross(J);
        b.s.velocity -= b.invMass.cwiseProduct(J);
        b.s.spin -= b.invI * c.rb.cross(J);
    };
    // The effective inverse mass of the contact along a direction: what an impulse of 1 changes its velocity by.
    const auto inverseMass = [&](const Contact& c, const Vec3d& d) {
        return d.dot(a.invMass.cwiseProduct(d) + (a.invI * c.ra.cross(d)).cross(c.ra)) +
               d.dot(b.invMass.cwiseProduct(d) + (b.invI * c.rb.cross(d)).cross(c.rb));
    };
    const auto relative = [&](const Contact& c) {
        return Vec3d(a.s.velocity + a.s.spin.cross(c.ra) - b.s.velocity - b.s.spin.cross(c.rb) - c.vc);
    };
    // Friction: the sliding stopped, within the cone |T| <= mu N. Returns the change of the friction impulse.
    const auto resistSliding = [&](Contact& c) {
        Vec3d vt = relative(c);
        vt -= vt.dot(c.n) * c.n;
        const double speed = vt.norm();
        if (!(speed > 0.0)) return 0.0;
        const Vec3d dir = vt / speed;
        const double kt = inverseMass(c, dir);
        if (!(kt > 0.0)) return 0.0;
        Vec3d tangential = c.tangential - (speed / kt) * dir;
        const double limit = c.mu * c.normal;
        if (tangential.norm() > limit) tangential *= limit / tangential.norm();
        push(c, tangential - c.tangential);
        const double change = (tangential - c.tangential).norm();
        c.tangential = tangential;
        return change;
    };
    // Rolling resistance: one couple for the whole set of contacts, against the relative spin about axes in the plane
    // of their mean normal, at most `rolling` times their summed normal impulse times their mean lever (the centre's
    // height over the contacts: a ball's radius), both weighted by the normal impulses: the normal force acting c h
    // ahead of the contact. A couple moves no centre, so momentum is untouched, and friction then keeps the contact
    // from slipping while it can (c < 1.4 mu for a ball).
    Vec3d couple = Vec3d::Zero();
    const auto resistRolling = [&] {
        Vec3d normals = Vec3d::Zero();
        double load = 0.0, moment = 0.0;
        for (const Contact& c : contacts) {
            normals += c.normal * c.n;
            load += c.normal;
            moment += c.normal * std::abs(c.ra.dot(c.n));
        }
        const double spread = normals.norm();
        if (!(load > 0.0) || !(spread > 0.0) || !(moment > 0.0)) return 0.0;
        const Vec3d n = normals / spread;
        const double lever = moment / load;
        Vec3d roll = a.s.spin - b.s.spin;
        roll -= roll.dot(n) * n;
        const double rate = roll.norm();
        if (!(rate > 0.0)) return 0.0;
        const Vec3d axis = roll / rate;
        // Only a rolling contact takes the couple: its pressed points within the couple's offset, c h either side, and
        // within kRollingPatch of the lever, along the way it rolls. A wider patch is a face, whose own normal forces
        // resist the same turn: with the couple on top of them the solve was free to shift the load among the face's
        // points, and their friction with it, which turned a sliding box about the vertical (a new user's trials:
        // 6.5 degrees at c = 0.1 contact by contact; 41 degrees at c = 1 with the offset alone as the bound).
        const Vec3d ahead = axis.cross(n);
        double lo = std::numeric_limits<double>::infinity(), hi = -lo;
        for (const Contact& c : contacts)
            if (c.normal > 0.0) lo = std::min(lo, c.ra.dot(ahead)), hi = std::max(hi, c.ra.dot(ahead));
        if (hi - lo > std::min(2.0 * rolling, kRollingPatch) * lever) return 0.0;
        const double k = axis.dot(a.invI * axis) + axis.dot(b.invI * axis);
        if (!(k > 0.0)) return 0.0;
        Vec3d next = couple - (rate / k) * axis;
        const double limit = rolling * load * lever;
        if (next.norm() > limit) next *= limit / next.norm();
        a.s.spin += a.invI * (next - couple);
        b.s.spin -= b.invI * (next - couple);
        const double change = (next - couple).norm() / lever;  // as an impulse, for the convergence test
        couple = next;
        return change;
    };
    for (Contact& c : contacts) {
        // No approach beyond the gap the step may close; a contact met within the step at speed bounces.
        c.target = c.depth < 0.0 ? c.depth / dt : 0.0;
        const double approach = relative(c).dot(c.n), met = approach - stepGravity.dot(c.n);
        if (c.restitution > 0.0 && met < -restingSpeed && approach * dt <= c.depth)
            c.target = std::max(c.target, -c.restitution * met);
    }
    // Sweeps until no impulse changes by more than kConverged of the largest: a body landing on a cluster of
    // samples (a faceted ball, a face) needs many, and stopped early it keeps a spin that rolls it away.
    for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
        double change = 0.0, largest = 0.0;
        for (Contact& c : contacts) {
            const double kn = inverseMass(c, c.n);
            if (!(kn > 0.0)) continue;
            // Normal: impulses only pushing (accumulated, clamped at 0).
            const double normal = std::max(c.normal + (c.target - relative(c).dot(c.n)) / kn, 0.0);
            push(c, (normal - c.normal) * c.n);
            change = std::max(change, std::abs(normal - c.normal));
            largest = std::max(largest, normal);
            c.normal = normal;
            change = std::max(change, resistSliding(c));
        }
        if (rolling > 0.0) change = std::max(change, resistRolling());
        if (sweep + 1 >= kMinSweeps && change <= kConverged * largest) break;
    }
    // Apart along the normals, the deepest first in effect: each contact pushes what is left. Against a fixed
    // collider only a's free axes move, so they alone count as pushed.
    const bool fixedB = b.invMass.isZero();
    Vec3d apart = Vec3d::Zero();
    for (int sweep = 0; sweep < kMinSweeps; ++sweep)
        for (const Contact& c : contacts) {
            const double left = c.depth - apart.dot(c.n);
            if (left > 0.0) apart += left * (fixedB ? c.n.cwiseProduct(a.moveFree) : c.n);
        }
    const double ka = apart.dot(a.invMass.cwiseProduct(apart)), kb = apart.dot(b.invMass.cwiseProduct(apart));
    if (ka + kb > 0.0) {
        a.s.centre += (ka / (ka + kb)) * apart.cwiseProduct(a.moveFree);
        b.s.centre -= (kb / (ka + kb)) * apart.cwiseProduct(b.moveFree);
    }
    double work = 0.0;
    for (const Contact& c : contacts) work += (c.normal * c.n + c.tangential).dot(c.vc);
    return work;
}

/// An approach slower than one step's gravity, g dt, does not bounce: the hops of a bouncing body shrink by e each,
/// and this ends them (as a real ball's end, in the time the step resolves).
double restingSpeed(const Vec3d& gravity, double dt) { return gravity.norm() * dt; }

double frictionOf(const Collider& c) {
    return c.boundary() == Boundary::Sticky ? std::numeric_limits<double>::infinity() : double(c.friction());
}

}  // namespace

int RigidBodyModel::touch(RigidBodyState& s, const std::vector<FixedCollider>& fixed, double t, double dt, const Vec3d& gravity,
                          double& work) const {
    work = 0.0;
    const Mat3d R = s.orientation.toRotationMatrix();
    std::vector<Contact> contacts;
    // Speculative contacts (points the next step could carry into a collider) keep a resting face on all its
    // points at once; touching only once inside, a box on a floor rocked from corner to corner.
    const double reach = std::sqrt(1.5 * inertia.trace() / mass);
    const double margin = 2.0 * dt * (s.velocity.norm() + s.spin.norm() * reach);
    for (std::size_t i = 0; i < contactPoints.size(); ++i) {
        const Vec3d p = s.centre + R * (contactPoints[i] - restCentre);
        const double radius = contactRadii[i];
        for (const FixedCollider& f : fixed) {
            const Collider* c = f.collider;
            const double phi = c->signedDistance(p, t) - radius;
            if (!(phi < margin)) continue;
            const Vec3d n = c->normal(p, t);
            const Vec3d q = p - radius * n;
            Contact contact{.ra = q - s.centre, .rb = Vec3d::Zero(), .n = n, .depth = -phi, .mu = frictionOf(*c)};
            contact.vc = c->velocity(q, t);
            contact.restitution = std::max(restitution, f.restitution);
            contacts.push_back(contact);
        }
    }
    if (contacts.empty()) return 0;
    RigidBodyState still;
    work = solveContacts(Side(s, *this), Side(still), contacts, dt, restingSpeed(gravity, dt),
                         dt * gravity.cwiseProduct(moveFree), rollingResistance);
    return int(contacts.size());
}

double RigidBodyModel::extent() const {
    double reach = 0.0;
    for (std::size_t i = 0; i < contactPoints.size(); ++i)
        reach = std::max(reach, (contactPoints[i] - restCentre).norm() + contactRadii[i]);
    return reach;
}

int touchBodies(const RigidBodyModel& A, RigidBodyState& a, const Collider& colliderA, const RigidBodyModel& B, RigidBodyState& b,
                const Collider& colliderB, double t, double dt, const Vec3d& gravity) {
    // What can meet within the step: the bounding spheres closer than the distance the two may close in dt.
    const double closing =
        2.0 * dt * (a.velocity.norm() + b.velocity.norm() + a.spin.norm() * A.extent() + b.spin.norm() * B.extent());
    if ((a.centre - b.centre).norm() > A.extent() + B.extent() + closing) return 0;
    const double friction = std::min(frictionOf(colliderA), frictionOf(colliderB));
    // The bouncier of the two sets the pair's restitution (a rubber ball bounces off anything).
    const double bounce = std::max(A.restitution, B.restitution);
    const double rolling = std::max(A.rollingResistance, B.rollingResistance);
    std::vector<Contact> contacts;
    // The samples of `from` against the shape of `into`; sign turns the normal so that it points from b to a.
    const auto sample = [&](const RigidBodyModel& M, const RigidBodyState& s, const Collider& into, double sign) {
        const Mat3d R = s.orientation.toRotationMatrix();
        for (std::size_t i = 0; i < M.contactPoints.size(); ++i) {
            const Vec3d p = s.centre + R * (M.contactPoints[i] - M.restCentre);
            const double phi = into.signedDistance(p, t) - M.contactRadii[i];
            if (!(phi < closing)) continue;
            const Vec3d n = into.normal(p, t);
            const Vec3d q = p - M.contactRadii[i] * n;
            contacts.push_back(Contact{
                .ra = q - a.centre, .rb = q - b.centre, .n = sign * n, .depth = -phi, .mu = friction, .restitution = bounce});
        }
    };
    sample(A, a, colliderB, 1.0);
    sample(B, b, colliderA, -1.0);
    if (contacts.empty()) return 0;
    solveContacts(Side(a, A), Side(b, B), contacts, dt, restingSpeed(gravity, dt),
                  dt * (gravity.cwiseProduct(A.moveFree) - gravity.cwiseProduct(B.moveFree)), rolling);
    return int(contacts.size());
}

double RigidBodyModel::energy(const RigidBodyState& s, const Vec3d& gravity, double dt) const {
    return 0.5 * mass * s.velocity.squaredNorm() + 0.5 * s.spin.dot(worldInertia(s.orientation) * s.spin) -
           mass * gravity.dot(s.centre) - 0.5 * dt * mass * gravity.dot(s.velocity);
}

BodyFrame RigidBodyModel::frame(const RigidBodyState& s) const {
    BodyFrame f;
    f.pose.R = s.orientation.toRotationMatrix();
    f.pose.T = s.centre - f.pose.R * restCentre;
    f.centre = s.centre;
    f.linear = s.velocity;
    f.angular = s.spin;
    return f;
}

}  // namespace mpm
