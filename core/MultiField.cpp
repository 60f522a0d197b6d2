#include "core/MultiField.h"

#include <cstdint>
#include <unordered_map>

#include "sparse/LeafParallel.h"

namespace mpm {

namespace {

struct OriginHash {
    std::size_t operator()(const Vec3i& o) const {
        uint64_t h = uint64_t(uint32_t(o[0])) * 0x9E3779B97F4A7C15ull;
        h ^= uint64_t(uint32_t(o[1])) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
        h ^= uint64_t(uint32_t(o[2])) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
        return std::size_t(h);
    }
};
using LeafIndex = std::unordered_map<Vec3i, uint32_t, OriginHash>;

/// The origin of the leaf holding a node (floor to a multiple of the leaf size, negative coordinates too).
Vec3i leafOriginOf(const Vec3i& node) { return Vec3i(node[0] & ~(kLeafDim - 1), node[1] & ~(kLeafDim - 1), node[2] & ~(kLeafDim - 1)); }

/// One field's leaves by origin, for the lookups of shared nodes and of the mass gradient's neighbours.
class FieldLookup {
public:
    explicit FieldLookup(const SparseGrid& grid) : grid_(&grid) {
        index_.reserve(grid.leafCount());
        for (std::size_t l = 0; l < grid.leafCount(); ++l) index_.emplace(grid.leaf(l).origin, uint32_t(l));
    }
    const LeafView* find(const Vec3i& origin) const {
        const auto it = index_.find(origin);
        return it == index_.end() ? nullptr : &grid_->leaf(it->second);
    }
    /// Mass at a node (zero where the field has no leaf: nothing of it reaches there).
    float massAt(const Vec3i& node, const LeafView* near) const {
        const Vec3i o = leafOriginOf(node);
        const LeafView* leaf = near && near->origin == o ? near : find(o);
        if (!leaf) return 0.0f;
        const Vec3i l = node - o;
        return leaf->mass[leafOffset(l[0], l[1], l[2])];
    }

private:
    const SparseGrid* grid_;
    LeafIndex index_;
};

/// Central difference of a field's node masses (the direction is all that is used; the spacing drops out).
Vec3f massGradient(const FieldLookup& field, const Vec3i& node, const LeafView* leaf) {
    Vec3f g;
    for (int a = 0; a < 3; ++a) {
        Vec3i up = node, down = node;
        ++up[a];
        --down[a];
        g[a] = 0.5f * (field.massAt(up, leaf) - field.massAt(down, leaf));
    }
    return g;
}

}  // namespace

FieldContactSummary resolveFieldContact(std::vector<SparseGrid>& fields, float friction) {
    const std::size_t F = fields.size();
    FieldContactSummary total;
    if (F < 2) return total;
    std::vector<FieldLookup> lookup;
    lookup.reserve(F);
    for (const SparseGrid& g : fields) lookup.emplace_back(g);
    for (std::size_t f = 0; f < F; ++f) {
        const SparseGrid& grid = fields[f];
        const FieldContactSummary s = reduceLeafRanges(
            grid.leafCount(), LeafGrain::Nodes, FieldContactSummary{},
            [&](std::size_t begin, std::size_t end, FieldContactSummary& acc) {
                std::vector<const LeafView*> same(F);
                std::vector<int> members;
                std::vector<Vec3f> gradient;
                for (std::size_t l = begin; l < end; ++l) {
                    const LeafView& leaf = grid.leaf(l);
                    bool shared = false;
                    for (std::size_t g = 0; g < F; ++g) {
                        same[g] = g == f ? &leaf : lookup[g].find(leaf.origin);
                        shared = shared || (g != f && same[g]);
                    }
                    if (!shared) continue;
                    grid.writtenBox(l).forEach([&](int n) {
                        if (leaf.mass[n] == 0.0f) return;
                        // The lowest field with mass here handles the node, once.
                        for (std::size_t g = 0; g < f; ++g)
                            if (same[g] && same[g]->mass[n] != 0.0f) return;
                        members.clear();
                        for (std::size_t g = f; g < F; ++g)
                            if (same[g] && same[g]->mass[n] != 0.0f) members.push_back(int(g));
                        if (members.size() < 2) return;
                        ++acc.nodes;
                        const Vec3i node = leaf.origin + leafLocal(n);
                        float mass = 0.0f;
                        Vec3f momentum = Vec3f::Zero(), sum = Vec3f::Zero();
                        gradient.resize(members.size());
                        for (std::size_t k = 0; k < members.size(); ++k) {
                            const LeafView& at = *same[members[k]];
                            mass += at.mass[n];
                            momentum += at.mass[n] * Eigen::Map<const Vec3f>(at.momentum + 3 * n);
                            gradient[k] = massGradient(lookup[members[k]], node, &at);
                            sum += gradient[k];
                        }
                        const Vec3f vcm = momentum / mass;
                        for (std::size_t k = 0; k < members.size(); ++k) {
                            // Outward normal of body k: towards the others' mass, away from its own.
                            Vec3f normal = sum - 2.0f * gradient[k];
                            const float len = normal.norm();
                            if (!(len > 0.0f)) continue;
                            normal /= len;
                            Eigen::Map<Vec3f> v(same[members[k]]->momentum + 3 * n);
                            const Vec3f rel = v - vcm;
                            const float approach = rel.dot(normal);
                            if (approach <= 0.0f) continue;  // moving apart: free
                            ++acc.contacts;
                            const Vec3f tangential = rel - approach * normal;
                            const float slide = tangential.norm();
                            if (slide <= friction * approach)
                                v = vcm;  // friction holds: the bodies move together here
                            else
                                v -= approach * normal + (friction * approach / slide) * tangential;
                        }
                    });
                }
            },
            [](FieldContactSummary a, const FieldContactSummary& b) {
                a.nodes += b.nodes;
                a.contacts += b.contacts;
                return a;
            });
        total.nodes += s.nodes;
        total.contacts += s.contacts;
    }
    return total;
}

}  // namespace mpm
