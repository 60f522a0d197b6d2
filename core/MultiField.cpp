#include "core/MultiField.h"

#include "sparse/LeafLookup.h"
#include "sparse/LeafParallel.h"

namespace mpm {

namespace {

/// Central difference of a field's node masses (the direction is all that is used; the spacing drops out).
Vec3f massGradient(const LeafLookup& field, const Vec3i& node, const LeafView* leaf) {
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
    std::vector<LeafLookup> lookup;
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
