#include "core/Motion.h"

#include <algorithm>
#include <cmath>

namespace mpm {

Mat3d rotationFromAxisDegrees(const Vec3d& axis, double degrees) {
    return Eigen::AngleAxisd(degrees * M_PI / 180.0, axis.normalized()).toRotationMatrix();
}

Motion Motion::constant(const Vec3d& velocity, const Vec3d& angularVelocity, const Vec3d& pivot) {
    Motion m;
    m.kind_ = velocity.isZero() && angularVelocity.isZero() ? Kind::None : Kind::Constant;
    m.velocity_ = velocity;
    m.angular_ = angularVelocity;
    m.pivot_ = pivot;
    return m;
}

Motion Motion::keyframes(std::vector<Key> keys, const Vec3d& pivot, double fps) {
    Motion m;
    m.kind_ = Kind::Keyframes;
    m.keys_ = std::move(keys);
    m.pivot_ = pivot;
    m.fps_ = fps;
    return m;
}

Motion Motion::dynamic(std::shared_ptr<const BodyFrame> frame, std::shared_ptr<const Motion> animation) {
    Motion m;
    m.kind_ = Kind::Dynamic;
    m.frame_ = std::move(frame);
    m.animation_ = std::move(animation);
    return m;
}

Pose Motion::at(double t) const {
    Pose pose;
    switch (kind_) {
        case Kind::None:
            return pose;
        case Kind::Dynamic:
            return animated() ? animation_->at(t) : frame_->pose;
        case Kind::Constant: {
            const double angle = angular_.norm() * t;
            pose.R = angle > 0.0 ? Eigen::AngleAxisd(angle, angular_.normalized()).toRotationMatrix() : Mat3d::Identity();
            pose.T = pivot_ + velocity_ * t - pose.R * pivot_;
            return pose;
        }
        case Kind::Keyframes: {
            const double f = t * fps_;
            // The segment [k, k + 1] holding f; before the first and after the last key, the pose is held.
            std::size_t k = 0;
            while (k + 1 < keys_.size() && keys_[k + 1].frame <= f) ++k;
            Vec3d p = keys_[k].position;
            Eigen::Quaterniond q = keys_[k].rotation;
            if (k + 1 < keys_.size() && f > keys_[k].frame) {
                const double s = (f - keys_[k].frame) / (keys_[k + 1].frame - keys_[k].frame);
                p = (1.0 - s) * keys_[k].position + s * keys_[k + 1].position;
                q = keys_[k].rotation.slerp(s, keys_[k + 1].rotation);
            }
            pose.R = q.toRotationMatrix();
            pose.T = p - pose.R * pivot_;
            return pose;
        }
    }
    return pose;
}

Motion::Rates Motion::ratesAt(double t, bool before) const {
    Rates r;
    switch (kind_) {
        case Kind::None:
            return r;
        case Kind::Dynamic:
            if (animated()) return animation_->ratesAt(t, before);
            // v_c(x) = v + w x (x - c), which velocityAt writes about the pose's origin T.
            r.angular = frame_->angular;
            r.linear = frame_->linear + frame_->angular.cross(frame_->pose.T - frame_->centre);
            return r;
        case Kind::Constant:
            // T(t) = pivot + v t - R pivot, so dT/dt = v - w x (R pivot) and v_c(x) = v + w x (x - pivot - v t).
            r.angular = angular_;
            r.linear = velocity_ + angular_.cross(at(t).T - (pivot_ + velocity_ * t));
            return r;
        case Kind::Keyframes: {
            const double f = t * fps_;
            // Held before the first key and after the last; at a key, the segment after it (or, before, the one ending there).
            if (keys_.size() < 2 || (before ? f <= keys_.front().frame || f > keys_.back().frame
                                            : f < keys_.front().frame || f >= keys_.back().frame))
                return r;
            std::size_t k = 0;
            while (k + 1 < keys_.size() && (before ? keys_[k + 1].frame < f : keys_[k + 1].frame <= f)) ++k;
            const double dt = (keys_[k + 1].frame - keys_[k].frame) / fps_;
            // Slerp turns at a constant rate about a fixed axis: w = axis angle / dt.
            Eigen::AngleAxisd turn(keys_[k + 1].rotation * keys_[k].rotation.inverse());
            if (turn.angle() > M_PI) turn = Eigen::AngleAxisd(2.0 * M_PI - turn.angle(), -turn.axis());  // slerp's short way
            r.angular = turn.axis() * turn.angle() / dt;
            const Vec3d pivotVelocity = (keys_[k + 1].position - keys_[k].position) / dt;
            // The pivot moves at pivotVelocity; v_c(x) = pivotVelocity + w x (x - p(t)), and p(t) = T + R pivot.
            const Pose pose = at(t);
            r.linear = pivotVelocity + r.angular.cross(pose.T - (pose.T + pose.R * pivot_));
            return r;
        }
    }
    return r;
}

}  // namespace mpm
