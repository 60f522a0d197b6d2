#include "core/MultiField.h"

#include <algorithm>

#include "sparse/LeafLookup.h"
#include "sparse/LeafParallel.h"

namespace mpm {

namespace {

/// Central difference of a field's node masses (the direction is all that is used; the spacing drops out).
/// `massAt(node)` reads the field.
template <class MassAt>
Vec3f massGradient(const Vec3i& node, MassAt&& massAt) {
    Vec3f g;
    for (int a = 0; a < 3; ++a) {
        Vec3i up = node, down = node;
        ++up[a];
        --down[a];
        g[a] = 0.5f * (massAt(up) - massAt(down));
    }
    return g;
}

/// The fields' leaves at one origin (null where a field has none), and whether two or more fields have one.
bool sameLeaves(const std::vector<LeafLookup>& lookup, std::size_t f, const LeafView& leaf, std::vector<const LeafView*>& same) {
    bool shared = false;
    for (std::size_t g = 0; g < lookup.size(); ++g) {
        same[g] = g == f ? &leaf : lookup[g].find(leaf.origin);
        shared = shared || (g != f && same[g]);
    }
    return shared;
}

/// The fields with mass at node n, if two or more do and f is the lowest of them (it handles the node, once).
bool membersAt(std::size_t f, int n, const std::vector<const LeafView*>& same, std::vector<int>& members) {
    if (same[f]->mass[n] == 0.0f) return false;
    for (std::size_t g = 0; g < f; ++g)
        if (same[g] && same[g]->mass[n] != 0.0f) return false;
    members.clear();
    for (std::size_t g = f; g < same.size(); ++g)
        if (same[g] && same[g]->mass[n] != 0.0f) members.push_back(int(g));
    return members.size() >= 2;
}

}  // namespace

FieldContactSummary resolveFieldContact(std::vector<SparseGrid>& fields, float friction, const RemoteFields* remote) {
    const std::size_t F = fields.size();
    FieldContactSummary total;
    if (F < 2) return total;
    std::vector<LeafLookup> lookup;
    lookup.reserve(F);
    for (const SparseGrid& g : fields) lookup.emplace_back(g);
    const auto handled = [&](std::size_t f, std::size_t l) { return !remote || (*remote->owned[f])[l]; };
    // On ranks: the masses the normals read in other ranks' leaves, per field, sorted, each once. The masses
    // are final (the velocities change below, the masses never), so they can be read first.
    std::vector<std::vector<Vec3i>> far(F);
    std::vector<std::vector<float>> farMass(F);
    if (remote) {
        std::vector<const LeafView*> same(F);
        std::vector<int> members;
        for (std::size_t f = 0; f < F; ++f)
            for (std::size_t l = 0; l < fields[f].leafCount(); ++l) {
                const LeafView& leaf = fields[f].leaf(l);
                if (!handled(f, l) || !sameLeaves(lookup, f, leaf, same)) continue;
                fields[f].writtenBox(l).forEach([&](int n) {
                    if (!membersAt(f, n, same, members)) return;
                    const Vec3i node = leaf.origin + leafLocal(n);
                    for (int g : members)
                        for (int a = 0; a < 3; ++a)
                            for (int step : {1, -1}) {
                                Vec3i next = node;
                                next[a] += step;
                                if (!remote->local(next)) far[std::size_t(g)].push_back(next);
                            }
                });
            }
        for (std::size_t g = 0; g < F; ++g) {
            std::sort(far[g].begin(), far[g].end(), nodeLess);
            far[g].erase(std::unique(far[g].begin(), far[g].end()), far[g].end());
            remote->fetch(g, far[g], farMass[g]);
        }
    }
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
                    if (!handled(f, l) || !sameLeaves(lookup, f, leaf, same)) continue;
                    grid.writtenBox(l).forEach([&](int n) {
                        if (!membersAt(f, n, same, members)) return;
                        ++acc.nodes;
                        const Vec3i node = leaf.origin + leafLocal(n);
                        float mass = 0.0f;
                        Vec3f momentum = Vec3f::Zero(), sum = Vec3f::Zero();
                        gradient.resize(members.size());
                        for (std::size_t k = 0; k < members.size(); ++k) {
                            const std::size_t g = std::size_t(members[k]);
                            const LeafView& at = *same[g];
                            mass += at.mass[n];
                            momentum += at.mass[n] * Eigen::Map<const Vec3f>(at.momentum + 3 * n);
                            gradient[k] = massGradient(node, [&](const Vec3i& x) {
                                if (remote && !remote->local(x))
                                    return farMass[g][std::size_t(std::lower_bound(far[g].begin(), far[g].end(), x, nodeLess) -
                                                                  far[g].begin())];
                                return lookup[g].massAt(x, &at);
                            });
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
