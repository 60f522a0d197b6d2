#include "core/LevelSet.h"

#include <cmath>

#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/Morphology.h>

#include "core/LevelSetGrid.h"

namespace mpm {

/// One voxel per 8^3 voxels of the level set, on where the band is, grown by the reach; or, for a reach of more
/// than kMaxMaskGrowth coarse cells, the band's box grown by the reach.
struct LevelSet::Near {
    openvdb::MaskGrid::Ptr mask;
    bool boxOnly = false;
    Vec3d lo = Vec3d::Zero(), hi = Vec3d::Zero();
};

namespace {
constexpr int kCoarseLog2 = 3;  ///< coarse cells of 8 voxels: the level set's own leaf nodes
/// Beyond this many coarse cells of reach the mask's dilation costs more than it saves (its voxels grow as the
/// cube of it: a scene of dx 1e6 m around a file of 1 cm voxels asked for 1e8 and stalled), and the band's box,
/// grown by the reach, tells near from far instead. Scenes reach 4 coarse cells at the default voxel of dx/2, 13 at dx/8.
constexpr int kMaxMaskGrowth = 64;
/// Sampler::outside looks at most this many leaves (a Poisson-disk tile covers a few in the fields scenes use; a
/// tile of a coarse sampling in a fine field is left to the search, whose cost it would exceed).
constexpr long long kMaxOutsideLeaves = 512;

/// Trilinear interpolation of the corners v[4 i + 2 j + k] of a voxel at the fraction f within it.
double trilinear(const double v[8], const Vec3d& f) {
    const double x00 = v[0] + f[2] * (v[1] - v[0]), x01 = v[2] + f[2] * (v[3] - v[2]);
    const double x10 = v[4] + f[2] * (v[5] - v[4]), x11 = v[6] + f[2] * (v[7] - v[6]);
    const double y0 = x00 + f[1] * (x01 - x00), y1 = x10 + f[1] * (x11 - x10);
    return y0 + f[0] * (y1 - y0);
}
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
                    for (int z = box.min().z() >> kCoarseLog2; z <= box.max().z() >> kCoarseLog2; ++z)
                        acc.setValueOn(openvdb::Coord(x, y, z));
        }
    const double grow = std::ceil(reach / cell) + 1.0;
    if (grow > kMaxMaskGrowth) {
        near->boxOnly = true;
        near->lo = lo_ - Vec3d::Constant(reach + cell), near->hi = hi_ + Vec3d::Constant(reach + cell);
    } else {
        openvdb::tools::dilateActiveValues(near->mask->tree(), int(grow), openvdb::tools::NN_FACE_EDGE_VERTEX,
                                           openvdb::tools::IGNORE_TILES);
    }
    near_ = near;
}

LevelSet::~LevelSet() = default;

void LevelSet::insideBounds(Vec3d& lo, Vec3d& hi) const {
    if (insideKept_) {
        lo = insideLo_, hi = insideHi_;
        return;
    }
    insideBoundsOf(*grid_->grid, lo, hi);
}

void insideBoundsOf(const openvdb::FloatGrid& g, Vec3d& lo, Vec3d& hi) {
    // The outermost inside voxels border the surface, so they lie in the band: the active values suffice.
    openvdb::CoordBBox box;
    for (auto it = g.tree().cbeginValueOn(); it; ++it)
        if (*it <= 0.0f) {
            openvdb::CoordBBox b;
            it.getBoundingBox(b);
            box.expand(b);
        }
    lo = Vec3d::Constant(INFINITY), hi = Vec3d::Constant(-INFINITY);
    if (box.empty()) return;
    const openvdb::BBoxd world = g.transform().indexToWorld(openvdb::BBoxd(box.min().asVec3d(), box.max().asVec3d()));
    lo = Vec3d(world.min().x(), world.min().y(), world.min().z());
    hi = Vec3d(world.max().x(), world.max().y(), world.max().z());
}

struct LevelSet::Sampler::Impl {
    const openvdb::FloatGrid& grid;
    openvdb::FloatGrid::ConstAccessor acc;
    double invVoxel;
    const Near& near;
    openvdb::MaskGrid::ConstAccessor nearAcc;
    const openvdb::math::Transform& xform;
    double invCoarse;
    Impl(const openvdb::FloatGrid& g, const Near& n)
        : grid(g),
          acc(g.getConstAccessor()),
          invVoxel(1.0 / g.voxelSize()[0]),
          near(n),
          nearAcc(n.mask->getConstAccessor()),
          xform(g.transform()),
          invCoarse(1.0 / double(1 << kCoarseLog2)) {}

    /// The 8 values around x and its fractional position among them.
    void corners(const Vec3d& x, double v[8], Vec3d& f) {
        const openvdb::Vec3d i = grid.worldToIndex(openvdb::Vec3d(x[0], x[1], x[2]));
        const openvdb::Coord c(int(std::floor(i[0])), int(std::floor(i[1])), int(std::floor(i[2])));
        f = Vec3d(i[0] - c.x(), i[1] - c.y(), i[2] - c.z());
        for (int k = 0; k < 8; ++k) v[k] = acc.getValue(c.offsetBy(k >> 2, (k >> 1) & 1, k & 1));
    }
};

LevelSet::Sampler::Sampler(const LevelSet& ls) : impl_(std::make_unique<Impl>(*ls.grid_->grid, *ls.near_)) {}

bool LevelSet::Sampler::far(const Vec3d& x) {
    if (impl_->near.boxOnly) return (x.array() < impl_->near.lo.array()).any() || (x.array() > impl_->near.hi.array()).any();
    // The coarse cell of x's voxel (the mask is in coarse cells of the level set's index space).
    const openvdb::Vec3d i = impl_->xform.worldToIndex(openvdb::Vec3d(x[0], x[1], x[2])) * impl_->invCoarse;
    return !impl_->nearAcc.isValueOn(openvdb::Coord(int(std::floor(i[0])), int(std::floor(i[1])), int(std::floor(i[2]))));
}
LevelSet::Sampler::~Sampler() = default;

bool LevelSet::Sampler::outside(const Vec3d& lo, const Vec3d& hi) {
    // The voxels the box's trilinear lookups read (the index box of its corners under any transform, grown by a
    // voxel for rounding), then the leaves over them: none may hold an active voxel there.
    openvdb::Vec3d a(INFINITY), b(-INFINITY);
    for (int k = 0; k < 8; ++k) {
        const openvdb::Vec3d i =
            impl_->xform.worldToIndex(openvdb::Vec3d(k & 4 ? hi[0] : lo[0], k & 2 ? hi[1] : lo[1], k & 1 ? hi[2] : lo[2]));
        a = openvdb::math::minComponent(a, i), b = openvdb::math::maxComponent(b, i);
    }
    constexpr double kLargestIndex = double(1 << 30);  // beyond it the voxels' coordinates overflow
    for (int d = 0; d < 3; ++d)
        if (!(std::abs(a[d]) < kLargestIndex && std::abs(b[d]) < kLargestIndex)) return false;
    using Leaf = openvdb::FloatTree::LeafNodeType;
    const openvdb::CoordBBox box(openvdb::Coord(int(std::floor(a[0])) - 1, int(std::floor(a[1])) - 1, int(std::floor(a[2])) - 1),
                                 openvdb::Coord(int(std::floor(b[0])) + 2, int(std::floor(b[1])) + 2, int(std::floor(b[2])) + 2));
    const openvdb::Coord l0 = box.min() >> Leaf::LOG2DIM, l1 = box.max() >> Leaf::LOG2DIM, leaves = l1 - l0 + openvdb::Coord(1);
    if ((long long)leaves.x() * leaves.y() * leaves.z() > kMaxOutsideLeaves) return false;
    auto& acc = impl_->acc;
    for (int x = l0.x(); x <= l1.x(); ++x)
        for (int y = l0.y(); y <= l1.y(); ++y)
            for (int z = l0.z(); z <= l1.z(); ++z) {
                const openvdb::Coord origin = openvdb::Coord(x, y, z) << Leaf::LOG2DIM;
                if (const Leaf* leaf = acc.probeConstLeaf(origin)) {
                    if (leaf->isEmpty()) continue;
                    openvdb::CoordBBox part = leaf->getNodeBoundingBox();
                    part.intersect(box);
                    for (auto v = part.begin(); v; ++v)
                        if (leaf->isValueOn(*v)) return false;
                } else if (acc.isValueOn(origin)) {
                    return false;  // an active tile (a whole leaf's worth of voxels or more)
                }
            }
    // No band voxel in reach: the field is +-background over the whole box, with one sign.
    return phi(0.5 * (lo + hi)) > 0.0;
}

double LevelSet::Sampler::phi(const Vec3d& x) {
    double v[8];
    Vec3d f;
    impl_->corners(x, v, f);
    return trilinear(v, f);
}

void LevelSet::Sampler::phiAndGradient(const Vec3d& x, double& phi, Vec3d& gradient) {
    Impl& m = *impl_;
    const openvdb::Vec3d i = m.grid.worldToIndex(openvdb::Vec3d(x[0], x[1], x[2]));
    const openvdb::Coord c(int(std::floor(i[0])), int(std::floor(i[1])), int(std::floor(i[2])));
    const Vec3d f(i[0] - c.x(), i[1] - c.y(), i[2] - c.z());
    // The values of the 4^3 block around x that the corners' central differences read, at (a, b, d) + 1.
    double v[4][4][4];
    for (int a = -1; a <= 2; ++a)
        for (int b = -1; b <= 2; ++b)
            for (int d = -1; d <= 2; ++d) {
                // Central differences at the 8 corners read the 2^3 core and its face neighbours, not the block's edges.
                const int outside = (a < 0 || a > 1) + (b < 0 || b > 1) + (d < 0 || d > 1);
                v[a + 1][b + 1][d + 1] = outside > 1 ? 0.0 : double(m.acc.getValue(c.offsetBy(a, b, d)));
            }
    // phi: trilinear in the 8 corners, as phi() takes it. Its gradient: the corners' central differences, blended
    // trilinearly. The interpolant's own derivative is a one-sided difference wherever x lies on a voxel's face (as a
    // grid node does whenever the voxel divides dx), which tilts the normal of a curved surface by up to half a
    // voxel's turn; the blend is symmetric there and continuous everywhere (docs/method.md, section 7).
    double corner[8];
    Vec3d g = Vec3d::Zero();
    for (int k = 0; k < 8; ++k) {
        const int a = k >> 2, b = (k >> 1) & 1, d = k & 1, A = a + 1, B = b + 1, D = d + 1;
        corner[k] = v[A][B][D];
        const double w = (a ? f[0] : 1.0 - f[0]) * (b ? f[1] : 1.0 - f[1]) * (d ? f[2] : 1.0 - f[2]);
        g += w * Vec3d(v[A + 1][B][D] - v[A - 1][B][D], v[A][B + 1][D] - v[A][B - 1][D], v[A][B][D + 1] - v[A][B][D - 1]);
    }
    phi = trilinear(corner, f);
    gradient = g * (0.5 * m.invVoxel);
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
