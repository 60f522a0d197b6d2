#include "core/LevelSet.h"

#include <cmath>

#include "core/LevelSetGrid.h"

namespace mpm {

LevelSet::LevelSet(std::shared_ptr<const Grid> grid) : grid_(std::move(grid)) {
    const openvdb::FloatGrid& g = *grid_->grid;
    voxel_ = g.voxelSize()[0];
    background_ = double(g.background());
    const openvdb::CoordBBox box = g.evalActiveVoxelBoundingBox();
    const openvdb::Vec3d a = g.indexToWorld(box.min().asVec3d()), b = g.indexToWorld(box.max().asVec3d());
    lo_ = Vec3d(std::min(a[0], b[0]), std::min(a[1], b[1]), std::min(a[2], b[2]));
    hi_ = Vec3d(std::max(a[0], b[0]), std::max(a[1], b[1]), std::max(a[2], b[2]));
}

LevelSet::~LevelSet() = default;

struct LevelSet::Sampler::Impl {
    const openvdb::FloatGrid& grid;
    openvdb::FloatGrid::ConstAccessor acc;
    double invVoxel;
    explicit Impl(const openvdb::FloatGrid& g) : grid(g), acc(g.getConstAccessor()), invVoxel(1.0 / g.voxelSize()[0]) {}

    /// The 8 values around x and its fractional position among them.
    void corners(const Vec3d& x, double v[8], Vec3d& f) {
        const openvdb::Vec3d i = grid.worldToIndex(openvdb::Vec3d(x[0], x[1], x[2]));
        const openvdb::Coord c(int(std::floor(i[0])), int(std::floor(i[1])), int(std::floor(i[2])));
        f = Vec3d(i[0] - c.x(), i[1] - c.y(), i[2] - c.z());
        for (int k = 0; k < 8; ++k) v[k] = acc.getValue(c.offsetBy(k >> 2, (k >> 1) & 1, k & 1));
    }
};

LevelSet::Sampler::Sampler(const LevelSet& ls) : impl_(std::make_unique<Impl>(*ls.grid_->grid)) {}
LevelSet::Sampler::~Sampler() = default;

double LevelSet::Sampler::phi(const Vec3d& x) {
    double v[8];
    Vec3d f;
    impl_->corners(x, v, f);
    const double x00 = v[0] + f[2] * (v[1] - v[0]), x01 = v[2] + f[2] * (v[3] - v[2]);
    const double x10 = v[4] + f[2] * (v[5] - v[4]), x11 = v[6] + f[2] * (v[7] - v[6]);
    const double y0 = x00 + f[1] * (x01 - x00), y1 = x10 + f[1] * (x11 - x10);
    return y0 + f[0] * (y1 - y0);
}

void LevelSet::Sampler::phiAndGradient(const Vec3d& x, double& phi, Vec3d& gradient) {
    double v[8];
    Vec3d f;
    impl_->corners(x, v, f);
    // Trilinear interpolation of the corners, k = 4 i + 2 j + l for the offset (i, j, l), and its derivatives.
    const double x00 = v[0] + f[2] * (v[1] - v[0]), x01 = v[2] + f[2] * (v[3] - v[2]);
    const double x10 = v[4] + f[2] * (v[5] - v[4]), x11 = v[6] + f[2] * (v[7] - v[6]);
    const double y0 = x00 + f[1] * (x01 - x00), y1 = x10 + f[1] * (x11 - x10);
    phi = y0 + f[0] * (y1 - y0);
    const double dz00 = v[1] - v[0], dz01 = v[3] - v[2], dz10 = v[5] - v[4], dz11 = v[7] - v[6];
    const double dz0 = dz00 + f[1] * (dz01 - dz00), dz1 = dz10 + f[1] * (dz11 - dz10);
    gradient = Vec3d(y1 - y0, (1.0 - f[0]) * (x01 - x00) + f[0] * (x11 - x10), dz0 + f[0] * (dz1 - dz0)) * impl_->invVoxel;
}

}  // namespace mpm
