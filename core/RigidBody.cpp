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

int RigidBodyModel::touch(RigidBodyState& s, const std::vector<const Collider*>& fixed, double t, double dt) const {
    struct Contact {
        Vec3d r, n, vc;       ///< from the centre to the contact point; the collider's outward normal and velocity there
        double depth;         ///< < 0: a gap the next step may close, no more
        double mu;            ///< infinite on a sticky collider
        double normal = 0.0;  ///< accumulated normal impulse
        Vec3d tangential = Vec3d::Zero();
    };
    const Mat3d R = s.orientation.toRotationMatrix();
    std::vector<Contact> contacts;
    // Speculative contacts (points the next step could carry into a collider) keep a resting face on all its
    // points at once; touching only once inside, a box on a floor rocked from corner to corner.
    const double reach = std::sqrt(1.5 * inertia.trace() / mass);
    const double margin = 2.0 * dt * (s.velocity.norm() + s.spin.norm() * reach);
    for (std::size_t i = 0; i < contactPoints.size(); ++i) {
        const Vec3d p = s.centre + R * (contactPoints[i] - restCentre);
        const double radius = contactRadii[i];
        for (const Collider* c : fixed) {
            const double phi = c->signedDistance(p, t) - radius;
            if (!(phi < margin)) continue;
            const Vec3d n = c->normal(p, t);
            const Vec3d q = p - radius * n;
            const double mu = c->boundary() == Boundary::Sticky ? std::numeric_limits<double>::infinity() : double(c->friction());
            contacts.push_back(Contact{q - s.centre, n, c->velocity(q, t), -phi, mu});
        }
    }
    if (contacts.empty()) return 0;
    // Locked axes take no impulse: the inverse mass and inertia act on the free ones alone.
    const Vec3d invMass = moveFree / mass;
    const Mat3d turn = turnFree.asDiagonal();
    const Mat3d invI = turn * worldInertia(s.orientation).inverse() * turn;
    const auto push = [&](const Vec3d& r, const Vec3d& J) {
        s.velocity += invMass.cwiseProduct(J);
        s.spin += invI * r.cross(J);
    };
    // The effective inverse mass of a point along a direction: what an impulse of 1 there changes its velocity by.
    const auto inverseMass = [&](const Vec3d& r, const Vec3d& d) {
        return d.dot(invMass.cwiseProduct(d) + (invI * r.cross(d)).cross(r));
    };
    constexpr int kSweeps = 8;
    for (int sweep = 0; sweep < kSweeps; ++sweep)
        for (Contact& c : contacts) {
            const auto relative = [&] { return Vec3d(s.velocity + s.spin.cross(c.r) - c.vc); };
            const double kn = inverseMass(c.r, c.n);
            if (!(kn > 0.0)) continue;
            // Normal: no approach beyond the gap the step may close, impulses only pushing (accumulated, clamped at 0).
            const double allowed = c.depth < 0.0 ? c.depth / dt : 0.0;
            const double normal = std::max(c.normal + (allowed - relative().dot(c.n)) / kn, 0.0);
            push(c.r, (normal - c.normal) * c.n);
            c.normal = normal;
            // Friction: the sliding stopped, within the cone |T| <= mu N.
            Vec3d vt = relative();
            vt -= vt.dot(c.n) * c.n;
            const double speed = vt.norm();
            if (!(speed > 0.0)) continue;
            const Vec3d dir = vt / speed;
            const double kt = inverseMass(c.r, dir);
            if (!(kt > 0.0)) continue;
            Vec3d tangential = c.tangential - (speed / kt) * dir;
            const double limit = c.mu * c.normal;
            if (tangential.norm() > limit) tangential *= limit / tangential.norm();
            push(c.r, tangential - c.tangential);
            c.tangential = tangential;
        }
    // Out of the colliders along their normals, the deepest first in effect: each contact pushes what is left.
    Vec3d out = Vec3d::Zero();
    for (int sweep = 0; sweep < kSweeps; ++sweep)
        for (const Contact& c : contacts) {
            const double left = c.depth - out.dot(c.n);
            if (left > 0.0) out += left * c.n.cwiseProduct(moveFree);
        }
    s.centre += out;
    return int(contacts.size());
}

double RigidBodyModel::extent() const {
    double reach = 0.0;
    for (std::size_t i = 0; i < contactPoints.size(); ++i)
        reach = std::max(reach, (contactPoints[i] - restCentre).norm() + contactRadii[i]);
    return reach;
}

int touchBodies(const RigidBodyModel& A, RigidBodyState& a, const Collider& colliderA, const RigidBodyModel& B, RigidBodyState& b,
                const Collider& colliderB, double t, double dt) {
    // What can meet within the step: the bounding spheres closer than the distance the two may close in dt.
    const double closing =
        2.0 * dt * (a.velocity.norm() + b.velocity.norm() + a.spin.norm() * A.extent() + b.spin.norm() * B.extent());
    if ((a.centre - b.centre).norm() > A.extent() + B.extent() + closing) return 0;
    struct Contact {
        Vec3d ra, rb, n;  ///< from each centre to the contact point; the normal pointing from b to a
        double depth;     ///< < 0: a gap the next step may close, no more
        double normal = 0.0;
        Vec3d tangential = Vec3d::Zero();
    };
    const auto mu = [](const Collider& c) {
        return c.boundary() == Boundary::Sticky ? std::numeric_limits<double>::infinity() : double(c.friction());
    };
    const double friction = std::min(mu(colliderA), mu(colliderB));
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
            contacts.push_back(Contact{q - a.centre, q - b.centre, sign * n, -phi});
        }
    };
    sample(A, a, colliderB, 1.0);
    sample(B, b, colliderA, -1.0);
    if (contacts.empty()) return 0;
    // Locked axes take no impulse.
    const Vec3d invMassA = A.moveFree / A.mass, invMassB = B.moveFree / B.mass;
    const Mat3d turnA = A.turnFree.asDiagonal(), turnB = B.turnFree.asDiagonal();
    const Mat3d invIA = turnA * A.worldInertia(a.orientation).inverse() * turnA;
    const Mat3d invIB = turnB * B.worldInertia(b.orientation).inverse() * turnB;
    // J acts on a at ra, -J on b at rb.
    const auto push = [&](const Contact& c, const Vec3d& J) {
        a.velocity += invMassA.cwiseProduct(J);
        a.spin += invIA * c.ra.cross(J);
        b.velocity -= invMassB.cwiseProduct(J);
        b.spin -= invIB * c.rb.cross(J);
    };
    const auto inverseMass = [&](const Contact& c, const Vec3d& d) {
        return d.dot(invMassA.cwiseProduct(d) + (invIA * c.ra.cross(d)).cross(c.ra)) +
               d.dot(invMassB.cwiseProduct(d) + (invIB * c.rb.cross(d)).cross(c.rb));
    };
    const auto relative = [&](const Contact& c) {
        return Vec3d(a.velocity + a.spin.cross(c.ra) - b.velocity - b.spin.cross(c.rb));
    };
    constexpr int kSweeps = 8;
    for (int sweep = 0; sweep < kSweeps; ++sweep)
        for (Contact& c : contacts) {
            const double kn = inverseMass(c, c.n);
            if (!(kn > 0.0)) continue;
            const double allowed = c.depth < 0.0 ? c.depth / dt : 0.0;
            const double normal = std::max(c.normal + (allowed - relative(c).dot(c.n)) / kn, 0.0);
            push(c, (normal - c.normal) * c.n);
            c.normal = normal;
            Vec3d vt = relative(c);
            vt -= vt.dot(c.n) * c.n;
            const double speed = vt.norm();
            if (!(speed > 0.0)) continue;
            const Vec3d dir = vt / speed;
            const double kt = inverseMass(c, dir);
            if (!(kt > 0.0)) continue;
            Vec3d tangential = c.tangential - (speed / kt) * dir;
            const double limit = friction * c.normal;
            if (tangential.norm() > limit) tangential *= limit / tangential.norm();
            push(c, tangential - c.tangential);
            c.tangential = tangential;
        }
    // Apart along the normals, what is left of each contact's depth, shared by the inverse masses along it.
    Vec3d apart = Vec3d::Zero();
    for (int sweep = 0; sweep < kSweeps; ++sweep)
        for (const Contact& c : contacts) {
            const double left = c.depth - apart.dot(c.n);
            if (left > 0.0) apart += left * c.n;
        }
    const double ka = apart.dot(invMassA.cwiseProduct(apart)), kb = apart.dot(invMassB.cwiseProduct(apart));
    if (ka + kb > 0.0) {
        a.centre += (ka / (ka + kb)) * apart.cwiseProduct(A.moveFree);
        b.centre -= (kb / (ka + kb)) * apart.cwiseProduct(B.moveFree);
    }
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
