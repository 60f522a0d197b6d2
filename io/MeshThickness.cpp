#include "io/MeshThickness.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>
#include <unsupported/Eigen/BVH>

#include <limits>

namespace mpm {

namespace {

/// A triangle of the mesh, as Eigen's KdBVH holds objects.
struct TriangleRef {
    const TriangleMesh* mesh;
    int index;
    Vec3d corner(int k) const { return mesh->points[std::size_t(mesh->triangles[std::size_t(index)][k])]; }
};

using Box = Eigen::AlignedBox<double, 3>;

/// Found by KdBVH's constructor through argument-dependent lookup.
Box bounding_box(const TriangleRef& t) {
    Box b(t.corner(0));
    b.extend(t.corner(1));
    b.extend(t.corner(2));
    return b;
}

constexpr double kMiss = std::numeric_limits<double>::max();

/// The first crossing of a ray with the mesh's triangles within `limit`, for Eigen's BVMinimize: a box's value is
/// where the ray enters it (a bound on every crossing inside), a triangle's where the ray crosses it.
struct RayCast {
    using Scalar = double;
    Vec3d origin, direction;
    int from;  ///< the triangle the ray leaves: never its own crossing
    double start, limit;

    double minimumOnVolume(const Box& box) const {
        // Slabs: the ray's parameter range inside the box on every axis.
        double lo = 0.0, hi = limit;
        for (int a = 0; a < 3; ++a) {
            if (direction[a] == 0.0) {
                if (origin[a] < box.min()[a] || origin[a] > box.max()[a]) return kMiss;
                continue;
            }
            double t0 = (box.min()[a] - origin[a]) / direction[a], t1 = (box.max()[a] - origin[a]) / direction[a];
            if (t0 > t1) std::swap(t0, t1);
            lo = std::max(lo, t0);
            hi = std::min(hi, t1);
            if (lo > hi) return kMiss;
        }
        return lo;
    }
    double minimumOnObject(const TriangleRef& t) const {
        if (t.index == from) return kMiss;
        // Moller and Trumbore 1997.
        const Vec3d a = t.corner(0), e1 = t.corner(1) - a, e2 = t.corner(2) - a;
        const Vec3d p = direction.cross(e2);
        const double det = e1.dot(p);
        if (std::abs(det) < 1e-300) return kMiss;  // the ray runs along the triangle's plane
        const Vec3d s = origin - a;
        const double u = s.dot(p) / det;
        if (u < 0.0 || u > 1.0) return kMiss;
        const Vec3d q = s.cross(e1);
        const double v = direction.dot(q) / det;
        if (v < 0.0 || u + v > 1.0) return kMiss;
        const double d = e2.dot(q) / det;
        return d > start && d <= limit ? d : kMiss;
    }
};

}  // namespace

WallThickness thinnestWall(const TriangleMesh& mesh, double limit, bool solidOutside) {
    std::vector<TriangleRef> refs;
    refs.reserve(mesh.triangles.size());
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i) refs.push_back({&mesh, int(i)});
    // Which way the triangles face: outwards when the signed volume (divergence theorem) is positive.
    double volume = 0.0;
    for (const TriangleRef& t : refs) volume += t.corner(0).dot(t.corner(1).cross(t.corner(2))) / 6.0;
    const double into = (volume >= 0.0) == !solidOutside ? -1.0 : 1.0;
    const Eigen::KdBVH<double, 3, TriangleRef> tree(refs.begin(), refs.end());
    WallThickness none;
    none.thinnest = limit;
    return tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, refs.size()), none,
        [&](const tbb::blocked_range<std::size_t>& r, WallThickness best) {
            for (std::size_t i = r.begin(); i < r.end(); ++i) {
                const TriangleRef& t = refs[i];
                const Vec3d n = (t.corner(1) - t.corner(0)).cross(t.corner(2) - t.corner(0));
                const double area2 = n.norm();
                if (!(area2 > 0.0)) continue;
                const Vec3d centroid = (t.corner(0) + t.corner(1) + t.corner(2)) / 3.0;
                // Crossings closer than round-off to the triangle's own plane are its neighbours' shared edges.
                const double start = 1e-9 * std::sqrt(area2);
                RayCast ray{centroid, into * n / area2, t.index, start, best.thinnest};
                const double d = Eigen::BVMinimize(tree, ray);
                if (d < best.thinnest) best = WallThickness{d, centroid, t.index};
            }
            return best;
        },
        [](const WallThickness& a, const WallThickness& b) {
            // The lowest triangle index wins a tie: the answer does not depend on how the work was split.
            if (a.thinnest != b.thinnest) return a.thinnest < b.thinnest ? a : b;
            return a.triangle <= b.triangle ? a : b;
        });
}

}  // namespace mpm
