#include "core/MultiField.h"

#include <algorithm>

#include "sparse/LeafLookup.h"
#include "sparse/LeafParallel.h"

namespace mpm {

namespace {

/// The 26 neighbours of a node and the node itself, as offsets.
constexpr int kStencil = 27;
Vec3i stencilOffset(int s) { return Vec3i(s / 9 - 1, (s / 3) % 3 - 1, s % 3 - 1); }

/// Gradients of each member body's mass fraction m_b / sum_c m_c at a node, from the 27 nodes around it: a
/// central difference along each axis averaged across the two others with weights 1, 2, 1 (Sobel's operator in
/// 3D). The spacing drops out: only the direction is used. A neighbour no member has mass at adds nothing.
/// `masses(s, out)` gives every member's mass at stencil node s.
template <class Masses>
void fractionGradients(std::size_t members, const float* centre, Masses&& masses, std::vector<float>& at,
                       std::vector<Vec3f>& gradient) {
    constexpr float kSmooth[3] = {1.0f, 2.0f, 1.0f};
    gradient.assign(members, Vec3f::Zero());
    at.resize(members);
    for (int s = 0; s < kStencil; ++s) {
        const Vec3i o = stencilOffset(s);
        if (o.isZero()) continue;
        masses(s, at);
        float total = 0.0f;
        for (float m : at) total += m;
        if (!(total > 0.0f)) continue;
        const Vec3f weight(float(o[0]) * kSmooth[o[1] + 1] * kSmooth[o[2] + 1],
                           float(o[1]) * kSmooth[o[0] + 1] * kSmooth[o[2] + 1],
                           float(o[2]) * kSmooth[o[0] + 1] * kSmooth[o[1] + 1]);
        for (std::size_t k = 0; k < members; ++k) gradient[k] += (at[k] / total - centre[k]) * weight;
    }
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
                        for (int st = 0; st < kStencil; ++st) {
                            const Vec3i next = node + stencilOffset(st);
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
                std::vector<float> fraction, neighbour;
                for (std::size_t l = begin; l < end; ++l) {
                    const LeafView& leaf = grid.leaf(l);
                    if (!handled(f, l) || !sameLeaves(lookup, f, leaf, same)) continue;
                    grid.writtenBox(l).forEach([&](int n) {
                        if (!membersAt(f, n, same, members)) return;
                        ++acc.nodes;
                        const Vec3i node = leaf.origin + leafLocal(n);
                        float mass = 0.0f;
                        Vec3f momentum = Vec3f::Zero();
                        fraction.resize(members.size());
                        for (std::size_t k = 0; k < members.size(); ++k) {
                            const LeafView& at = *same[std::size_t(members[k])];
                            mass += at.mass[n];
                            momentum += at.mass[n] * Eigen::Map<const Vec3f>(at.momentum + 3 * n);
                        }
                        for (std::size_t k = 0; k < members.size(); ++k)
                            fraction[k] = same[std::size_t(members[k])]->mass[n] / mass;
                        fractionGradients(
                            members.size(), fraction.data(),
                            [&](int st, std::vector<float>& m) {
                                const Vec3i x = node + stencilOffset(st);
                                for (std::size_t k = 0; k < members.size(); ++k) {
                                    const std::size_t g = std::size_t(members[k]);
                                    if (remote && !remote->local(x))
                                        m[k] = farMass[g][std::size_t(
                                            std::lower_bound(far[g].begin(), far[g].end(), x, nodeLess) - far[g].begin())];
                                    else
                                        m[k] = lookup[g].massAt(x, same[g]);
                                }
                            },
                            neighbour, gradient);
                        Vec3f sum = Vec3f::Zero();
                        for (const Vec3f& gk : gradient) sum += gk;
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
