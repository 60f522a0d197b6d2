#include "core/LevelSet.h"

#include <cmath>

#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/Morphology.h>

#include "core/LevelSetGrid.h"

namespace mpm {

/// One voxel per 8^3 voxels of the level set, on where the band is, grown by the reach.
struct LevelSet::Near {
    openvdb::MaskGrid::Ptr mask;
};

namespace {
constexpr int kCoarseLog2 = 3;  ///< coarse cells of 8 voxels: the level set's own leaf nodes
}  // namespace

LevelSet::LevelSet(std::shared_ptr<const Grid> grid, double reach) : grid_(std::move(grid)) {
    const openvdb::FloatGrid& g = *grid_->grid;
    voxel_ = g.voxelSize()[0];
    background_ = double(g.background());
    const openvdb::CoordBBox box = g.evalActiveVoxelBoundingBox();
    const openvdb::Vec3d a = g.indexToWorld(box.min().asVec3d()), b = g.indexToWorld(box.max().asVec3d());
    lo_ = Vec3d(std::min(a[0], b[0]), std::min(a[1], b[1]), std::min(a[2], b[2]));
    hi_ = Vec3d(std::max(a[0], b[0]), std::max(a[1], b[1]), std::max(a[2], b[2]));
    // The coarse mask: every leaf (and active tile) of the band, then grown by the reach in coarse cells.
    auto near = std::make_shared<Near>();
    near->mask = openvdb::MaskGrid::create();
    const double cell = voxel_ * (1 << kCoarseLog2);
    auto acc = near->mask->getAccessor();
    for (auto it = g.tree().cbeginLeaf(); it; ++it) {
        const openvdb::Coord o = it->origin();
        acc.setValueOn(openvdb::Coord(o.x() >> kCoarseLog2, o.y() >> kCoarseLog2, o.z() >> kCoarseLog2));
    }
    for (auto it = g.tree().cbeginValueOn(); it; ++it)
        if (it.isTileValue()) {
            openvdb::CoordBBox box;
            it.getBoundingBox(box);
            for (int x = box.min().x() >> kCoarseLog2; x <= box.max().x() >> kCoarseLog2; ++x)
                for (int y = box.min().y() >> kCoarseLog2; y <= box.max().y() >> kCoarseLog2; ++y)
                    for (int z = box.min().z() >> kCoarseLog2; z <= box.max().z() >> kCoarseLog2; ++z) acc.setValueOn(openvdb::Coord(x, y, z));
        }
    const int grow = int(std::ceil(reach / cell)) + 1;
    openvdb::tools::dilateActiveValues(near->mask->tree(), grow, openvdb::tools::NN_FACE_EDGE_VERTEX, openvdb::tools::IGNORE_TILES);
    near_ = near;
}

LevelSet::~LevelSet() = default;

struct LevelSet::Sampler::Impl {
    const openvdb::FloatGrid& grid;
    openvdb::FloatGrid::ConstAccessor acc;
    double invVoxel;
    openvdb::MaskGrid::ConstAccessor nearAcc;
    const openvdb::math::Transform& xform;
    double invCoarse;
    Impl(const openvdb::FloatGrid& g, const openvdb::MaskGrid& near)
        : grid(g), acc(g.getConstAccessor()), invVoxel(1.0 / g.voxelSize()[0]), nearAcc(near.getConstAccessor()), xform(g.transform()),
          invCoarse(1.0 / double(1 << kCoarseLog2)) {}

    /// The 8 values around x and its fractional position among them.
    void corners(const Vec3d& x, double v[8], Vec3d& f) {
        const openvdb::Vec3d i = grid.worldToIndex(openvdb::Vec3d(x[0], x[1], x[2]));
        const openvdb::Coord c(int(std::floor(i[0])), int(std::floor(i[1])), int(std::floor(i[2])));
        f = Vec3d(i[0] - c.x(), i[1] - c.y(), i[2] - c.z());
        for (int k = 0; k < 8; ++k) v[k] = acc.getValue(c.offsetBy(k >> 2, (k >> 1) & 1, k & 1));
    }
};

LevelSet::Sampler::Sampler(const LevelSet& ls) : impl_(std::make_unique<Impl>(*ls.grid_->grid, *ls.near_->mask)) {}

bool LevelSet::Sampler::far(const Vec3d& x) {
    // The coarse cell of x's voxel (the mask is in coarse cells of the level set's index space).
    const openvdb::Vec3d i = impl_->xform.worldToIndex(openvdb::Vec3d(x[0], x[1], x[2])) * impl_->invCoarse;
    return !impl_->nearAcc.isValueOn(openvdb::Coord(int(std::floor(i[0])), int(std::floor(i[1])), int(std::floor(i[2]))));
}
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

struct VectorField::Sampler::Impl {
    // The sampler keeps a reference to the accessor: the accessor is declared, and so built, first.
    openvdb::Vec3SGrid::ConstAccessor acc;
    openvdb::tools::GridSampler<openvdb::Vec3SGrid::ConstAccessor, openvdb::tools::BoxSampler> sampler;
    explicit Impl(const openvdb::Vec3SGrid& g) : acc(g.getConstAccessor()), sampler(acc, g.transform()) {}
};

VectorField::Sampler::Sampler(const VectorField& f) : impl_(std::make_unique<Impl>(*f.grid_->grid)) {}
VectorField::Sampler::~Sampler() = default;

Vec3d VectorField::Sampler::value(const Vec3d& x) {
    const openvdb::Vec3s v = impl_->sampler.wsSample(openvdb::Vec3d(x[0], x[1], x[2]));
    return Vec3d(v[0], v[1], v[2]);
}

}  // namespace mpm
