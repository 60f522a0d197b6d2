// The Simulation's ranks (docs/distributed.md): leaves cut in Morton order among the ranks and re-cut as the
// particles move, particles sent to the rank that owns their leaf, the halo of P2G parts and ghost velocities
// exchanged across the cut, and the gathers a single file or checkpoint needs. The substep itself
// (core/Simulation.cpp) calls these where it meets a cut.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cstring>
#include <type_traits>

#include "core/Simulation.h"
#include "sparse/LeafLookup.h"

namespace mpm {

namespace {
/// Particles per task when finding each particle's owner.
constexpr std::size_t kOwnerGrain = 16384;
/// Beyond every leaf in Morton order (leaf coordinates stay within 2^27 of the origin).
const Vec3i kPastLastLeaf(1 << 29, 1 << 29, 1 << 29);

/// Keeps the particles (every array of the species) i for which keep(i), in order; keep must not read the
/// species' arrays, which it compacts one after another.
template <class S, class Keep>
void keepWhere(S& sp, Keep&& keep) {
    sp.forEachArray([&](auto& arr) {
        std::size_t k = 0;
        for (std::size_t i = 0; i < arr.size(); ++i)
            if (keep(i)) arr[k++] = arr[i];
        arr.resize(k);
    });
}
/// Appends particles `which` of a species to a byte buffer: their count, then array by array.
template <class S>
void pack(const S& sp, const std::vector<uint32_t>& which, Bytes& b) {
    put(b, uint64_t(which.size()));
    sp.forEachArray([&](const auto& arr) {
        using T = typename std::decay_t<decltype(arr)>::value_type;
        const std::size_t at = b.size();
        b.resize(at + which.size() * sizeof(T));
        for (std::size_t k = 0; k < which.size(); ++k)
            std::memcpy(b.data() + at + k * sizeof(T), static_cast<const void*>(&arr[which[k]]), sizeof(T));
    });
}
/// The particles [begin, end) of a species.
std::vector<uint32_t> range(std::size_t begin, std::size_t end) {
    std::vector<uint32_t> r(end - begin);
    for (std::size_t i = begin; i < end; ++i) r[i - begin] = uint32_t(i);
    return r;
}
template <class S>
void unpackAppend(S& sp, ByteReader& r) {
    const uint64_t n = r.get<uint64_t>();
    sp.forEachArray([&](auto& arr) {
        const std::size_t n0 = arr.size();
        arr.resize(n0 + n);
        r.getArray(arr.data() + n0, n);
    });
}
}  // namespace

int Simulation::ownerOf(const Vec3i& leafCoord) const {
    return int(std::upper_bound(splitters_.begin(), splitters_.end(), leafCoord, mortonLess) - splitters_.begin());
}

namespace {
/// Leaf counts sorted in Morton order with each leaf's entries added up (a leaf may come several times).
std::vector<std::pair<Vec3i, long long>> mergeCounts(std::vector<std::pair<Vec3i, long long>> all) {
    std::stable_sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return mortonLess(a.first, b.first); });
    std::vector<std::pair<Vec3i, long long>> merged;
    for (const auto& e : all) {
        if (!merged.empty() && merged.back().first == e.first)
            merged.back().second += e.second;
        else
            merged.push_back(e);
    }
    return merged;
}
/// How many of the positions fall in each leaf, in Morton order.
template <class Leaf>
std::vector<std::pair<Vec3i, long long>> countPerLeaf(const std::vector<Vec3d>& x, Leaf&& leafOf) {
    std::vector<Vec3i> leaves;
    leaves.reserve(x.size());
    for (const Vec3d& p : x) leaves.push_back(leafOf(p));
    tbb::parallel_sort(leaves.begin(), leaves.end(), mortonLess);
    std::vector<std::pair<Vec3i, long long>> counts;
    for (const Vec3i& c : leaves) {
        if (counts.empty() || counts.back().first != c) counts.emplace_back(c, 0);
        ++counts.back().second;
    }
    return counts;
}
}  // namespace

std::vector<std::pair<Vec3i, long long>> Simulation::particlesPerLeaf() const {
    const auto leafOf = [&](const Vec3d& x) { return particleLeaf(x); };
    std::vector<std::pair<Vec3i, long long>> all;
    for (const AnySpecies& s : state_.species) {
        const auto c = countPerLeaf(particlesOf(s).x, leafOf);
        all.insert(all.end(), c.begin(), c.end());
    }
    return state_.species.size() == 1 ? all : mergeCounts(std::move(all));
}

std::vector<std::pair<Vec3i, long long>> Simulation::mergedOverRanks(const std::vector<std::pair<Vec3i, long long>>& mine) const {
    // A leaf's particles can sit on several ranks (until they migrate, as checkpoint parts left them, or as
    // the ranks' parts of a set fall).
    Bytes b;
    for (const auto& [c, n] : mine) {
        for (int a = 0; a < 3; ++a) put(b, int32_t(c[a]));
        put(b, n);
    }
    std::vector<std::pair<Vec3i, long long>> all;
    for (const Bytes& part : comm_->allGather(b)) {
        ByteReader r{part};
        while (!r.done()) {
            Vec3i c;
            for (int a = 0; a < 3; ++a) c[a] = r.get<int32_t>();
            all.emplace_back(c, r.get<long long>());
        }
    }
    return mergeCounts(std::move(all));
}

void Simulation::cutLeaves(const std::vector<std::pair<Vec3i, long long>>& leafCounts) {
    // Equal shares of particles: rank r's range starts at the first leaf with r / R of them before it.
    const long long R = comm_->size();
    long long total = 0;
    for (const auto& [c, n] : leafCounts) total += n;
    splitters_.assign(std::size_t(R - 1), kPastLastLeaf);
    long long before = 0;
    std::size_t next = 0;
    for (const auto& [c, n] : leafCounts) {
        while (next < splitters_.size() && before * R >= total * (long long)(next + 1)) splitters_[next++] = c;
        before += n;
    }
    // How unequal the cut is (a leaf is not split): re-cutting is pointless until motion adds to it.
    std::vector<long long> load(std::size_t(R), 0);
    for (const auto& [c, n] : leafCounts) load[std::size_t(ownerOf(c))] += n;
    const double mean = double(total) / double(R);
    cutImbalance_ = mean > 0.0 ? double(*std::max_element(load.begin(), load.end())) / mean - 1.0 : 0.0;
}

void Simulation::distribute(const Comm& comm) {
    comm_ = &comm;
    guard_.setComm(&comm);
    if (!comm.distributed()) return;
    // Every rank holds every particle here (or its share: then the counts are every rank's, merged), and the
    // same emitters, so each computes the same cut: from the particles, and from the sets about to be emitted
    // at this frame. Called before the first emission, no rank ever holds the whole scene's particles.
    // Sets sampled in parts (each rank holding its own) are counted over every rank.
    std::vector<std::pair<Vec3i, long long>> counts = particlesPerLeaf();
    bool parts = holdsShare_;
    if (state_.emittedFrame != state_.frame) {
        const auto leafOf = [&](const Vec3d& x) { return particleLeaf(x); };
        for (const Emitter& e : emitters_)
            if (e.emitsAt(state_.frame)) {
                const auto c = countPerLeaf(e.positions, leafOf);
                counts.insert(counts.end(), c.begin(), c.end());
                parts = parts || e.holdsPart();
            }
        counts = mergeCounts(std::move(counts));
    }
    cutLeaves(parts ? mergedOverRanks(counts) : counts);
    partitioned_ = true;
    if (holdsShare_) {
        // Each rank read some parts: the particles go to their leaves' owners, and every rank learns which
        // species have particles somewhere.
        migrateParticles();
        for (std::size_t s = 0; s < populated_.size(); ++s) populated_[s] = comm.sum((long long)populated_[s]) > 0;
        holdsShare_ = false;
    }
    for (AnySpecies& s : state_.species)
        std::visit(
            [&](auto& sp) {
                // Owners first: keepWhere moves the positions before the other arrays.
                std::vector<int>& owner = ownerScratch_;
                owner.resize(sp.p.size());
                for (std::size_t i = 0; i < owner.size(); ++i) owner[i] = ownerOf(particleLeaf(sp.p.x[i]));
                keepWhere(sp, [&](std::size_t i) { return owner[i] == comm.rank(); });
                sp.forEachArray([](auto& arr) { arr.shrink_to_fit(); });  // the whole scene's memory goes back
                sp.leafStart.clear();
            },
            s);
}

void Simulation::rebalanceIfNeeded() {
    const long long mine = (long long)particleCount();
    const long long total = comm_->sum(mine);
    const double most = comm_->max(double(mine));
    const double mean = double(total) / double(comm_->size());
    if (total == 0 || most <= mean * (1.0 + cutImbalance_ + settings_.rebalanceImbalance)) return;
    cutLeaves(allParticlesPerLeaf());
    ++rebalances_;
}

void Simulation::migrateParticles() {
    const int R = comm_->size(), me = comm_->rank();
    std::vector<Bytes> out(static_cast<std::size_t>(R));
    for (AnySpecies& s : state_.species)
        std::visit(
            [&](auto& sp) {
                // The owner of each particle's leaf, in a buffer kept between substeps (no allocation per substep).
                std::vector<int>& owner = ownerScratch_;
                owner.resize(sp.p.size());
                tbb::parallel_for(tbb::blocked_range<std::size_t>(0, owner.size(), kOwnerGrain), [&](const auto& r) {
                    for (std::size_t i = r.begin(); i < r.end(); ++i) owner[i] = ownerOf(particleLeaf(sp.p.x[i]));
                });
                // Few leave in a substep (those crossing a range's boundary): pack and compact only when some do.
                std::vector<std::vector<uint32_t>> leaving(static_cast<std::size_t>(R));
                for (std::size_t i = 0; i < owner.size(); ++i)
                    if (owner[i] != me) leaving[std::size_t(owner[i])].push_back(uint32_t(i));
                bool any = false;
                for (int r = 0; r < R; ++r) {
                    if (r == me) continue;
                    pack(sp, leaving[std::size_t(r)], out[std::size_t(r)]);
                    any = any || !leaving[std::size_t(r)].empty();
                }
                if (any) keepWhere(sp, [&](std::size_t i) { return owner[i] == me; });
            },
            s);
    const std::vector<Bytes> in = comm_->exchange(out);
    for (int r = 0; r < R; ++r) {
        if (r == me || in[std::size_t(r)].empty()) continue;
        ByteReader reader{in[std::size_t(r)]};
        for (AnySpecies& s : state_.species) std::visit([&](auto& sp) { unpackAppend(sp, reader); }, s);
    }
}

void Simulation::sendEmittedToOwners(int s, std::size_t from) {
    // Only the particles from `from` on move: those before (binned at the last substep) keep their places.
    const int R = comm_->size(), me = comm_->rank();
    std::vector<Bytes> out(static_cast<std::size_t>(R));
    AnySpecies& species = state_.species.at(std::size_t(s));
    std::visit(
        [&](auto& sp) {
            std::vector<int> owner(sp.p.size() - from);
            std::vector<std::vector<uint32_t>> leaving(static_cast<std::size_t>(R));
            for (std::size_t i = from; i < sp.p.size(); ++i) {
                owner[i - from] = ownerOf(particleLeaf(sp.p.x[i]));
                if (owner[i - from] != me) leaving[std::size_t(owner[i - from])].push_back(uint32_t(i));
            }
            for (int r = 0; r < R; ++r)
                if (!leaving[std::size_t(r)].empty()) pack(sp, leaving[std::size_t(r)], out[std::size_t(r)]);
            keepWhere(sp, [&](std::size_t i) { return i < from || owner[i - from] == me; });
        },
        species);
    const std::vector<Bytes> in = comm_->exchange(out);
    std::visit(
        [&](auto& sp) {
            for (int r = 0; r < R; ++r) {
                if (r == me || in[std::size_t(r)].empty()) continue;
                ByteReader reader{in[std::size_t(r)]};
                unpackAppend(sp, reader);
            }
            // The newcomers in id order, as one process holds a set's particles after emitting it.
            std::vector<uint32_t> order(sp.p.size() - from);
            for (std::size_t i = 0; i < order.size(); ++i) order[i] = uint32_t(from + i);
            std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return sp.p.id[a] < sp.p.id[b]; });
            sp.forEachArray([&](auto& arr) {
                std::decay_t<decltype(arr)> sorted(order.size());
                for (std::size_t k = 0; k < order.size(); ++k) sorted[k] = arr[order[k]];
                std::copy(sorted.begin(), sorted.end(), arr.begin() + std::ptrdiff_t(from));
            });
        },
        species);
}

RemoteHalos Simulation::remoteHalos(std::size_t f) {
    RankLeaves& rl = rankLeaves_[f];
    RemoteHalos remote;
    remote.owned = &rl.owned;
    remote.exchange = [this, &rl](HaloParts&& out) {
        return communicating([&] {
            std::vector<Bytes> send(static_cast<std::size_t>(comm_->size()));
            for (const HaloParts::Part& part : out.parts) {
                Bytes& b = send[std::size_t(ownerOf(part.leaf))];
                for (int a = 0; a < 3; ++a) put(b, int32_t(part.leaf[a]));
                put(b, part.d);
                putArray(b, part.lo, 3);
                putArray(b, part.hi, 3);
                std::size_t n = 1;
                for (int a = 0; a < 3; ++a) n *= std::size_t(part.hi[a] - part.lo[a]);
                put(b, uint64_t(n));
                putArray(b, out.data.data() + 4 * part.offset, 4 * n);
            }
            const std::vector<Bytes> received = comm_->exchange(send);
            HaloParts in;
            // What each rank's stencils read of a ghost leaf is what its parts wrote there: the velocities go
            // back for that box alone, not for all the owner wrote.
            rl.ghostBoxFor.assign(received.size(), {});
            for (std::size_t from = 0; from < received.size(); ++from) {
                const Bytes& b = received[from];
                const std::vector<Vec3i>& coords = rl.ghostCoordsFor[from];
                rl.ghostBoxFor[from].assign(coords.size(), NodeBox{});
                ByteReader r{b};
                while (!r.done()) {
                    HaloParts::Part part;
                    for (int a = 0; a < 3; ++a) part.leaf[a] = r.get<int32_t>();
                    part.d = r.get<int32_t>();
                    r.getArray(part.lo, 3);
                    r.getArray(part.hi, 3);
                    const auto at = std::lower_bound(coords.begin(), coords.end(), part.leaf, mortonLess);
                    if (at != coords.end() && *at == part.leaf) {
                        NodeBox box;
                        for (int a = 0; a < 3; ++a) {
                            const int shift = kLeafDim * neighbourStep(part.d, a);
                            box.lo[a] = int8_t(part.lo[a] - shift);
                            box.hi[a] = int8_t(part.hi[a] - shift);
                        }
                        rl.ghostBoxFor[from][std::size_t(at - coords.begin())].add(box);
                    }
                    const std::size_t n = r.get<uint64_t>();
                    part.offset = in.data.size() / 4;
                    in.data.resize(in.data.size() + 4 * n);
                    r.getArray(in.data.data() + 4 * part.offset, 4 * n);
                    in.parts.push_back(part);
                }
            }
            return in;
        });
    };
    return remote;
}

void Simulation::ownLeaves(const SparseGrid& grid, RankLeaves& rl) const {
    rl.owned.assign(grid.leafCount(), 0);
    for (auto& g : rl.ghostsFrom) g.clear();
    rl.ghostsFrom.resize(std::size_t(comm_->size()));
    for (std::size_t l = 0; l < grid.leafCount(); ++l) {
        const int owner = ownerOf(leafOfNode(grid.leaf(l).origin));
        if (owner == comm_->rank())
            rl.owned[l] = 1;
        else
            rl.ghostsFrom[std::size_t(owner)].push_back(uint32_t(l));
    }
    rl.ghostsFor.assign(std::size_t(comm_->size()), {});
    for (std::size_t r = 0; r < rl.ghostCoordsFor.size(); ++r)
        for (const Vec3i& c : rl.ghostCoordsFor[r]) rl.ghostsFor[r].push_back(grid.indexOfLeaf(c));
}

void Simulation::exchangeReachedLeaves(SparseGrid& grid, RankLeaves& leaves) {
    // Each rank tells the owners of the leaves its stencils reach that it holds them as ghosts: the owner
    // must allocate them (its own particles may not reach them) and send their velocities back.
    const int R = comm_->size(), me = comm_->rank();
    std::vector<Bytes> out(static_cast<std::size_t>(R));
    for (const Vec3i& c : grid.reachedLeaves()) {
        const int owner = ownerOf(c);
        if (owner == me) continue;
        for (int a = 0; a < 3; ++a) put(out[std::size_t(owner)], int32_t(c[a]));
    }
    const std::vector<Bytes> in = comm_->exchange(out);
    leaves.ghostCoordsFor.assign(std::size_t(R), {});
    std::vector<Vec3i> all;
    for (int r = 0; r < R; ++r) {
        if (r == me) continue;
        ByteReader reader{in[std::size_t(r)]};
        while (!reader.done()) {
            Vec3i c;
            for (int a = 0; a < 3; ++a) c[a] = reader.get<int32_t>();
            leaves.ghostCoordsFor[std::size_t(r)].push_back(c);
            all.push_back(c);
        }
    }
    grid.addReachedLeaves(all);
}

void Simulation::sendGhostVelocities(SparseGrid& grid, const RankLeaves& leaves) {
    // Owners send the nodes P2G wrote in each ghost leaf (box, then velocities); holders replace theirs.
    const int R = comm_->size(), me = comm_->rank();
    std::vector<Bytes> out(static_cast<std::size_t>(R));
    for (int r = 0; r < R; ++r) {
        if (r == me) continue;
        Bytes& b = out[std::size_t(r)];
        for (std::size_t k = 0; k < leaves.ghostsFor[std::size_t(r)].size(); ++k) {
            const uint32_t l = leaves.ghostsFor[std::size_t(r)][k];
            const NodeBox& box = leaves.ghostBoxFor[std::size_t(r)][k];
            putArray(b, box.lo, 3);
            putArray(b, box.hi, 3);
            const float* v = grid.leaf(l).momentum;
            box.forEach([&](int n) { putArray(b, v + 3 * n, 3); });
        }
    }
    const std::vector<Bytes> in = comm_->exchange(out);
    for (int r = 0; r < R; ++r) {
        if (r == me) continue;
        ByteReader reader{in[std::size_t(r)]};
        for (uint32_t l : leaves.ghostsFrom[std::size_t(r)]) {
            const LeafView& leaf = grid.leaf(l);
            grid.writtenBox(l).forEach([&](int n) {
                leaf.mass[n] = 0.0f;
                leaf.momentum[3 * n] = leaf.momentum[3 * n + 1] = leaf.momentum[3 * n + 2] = 0.0f;
            });
            NodeBox box;
            reader.getArray(box.lo, 3);
            reader.getArray(box.hi, 3);
            box.forEach([&](int n) { reader.getArray(leaf.momentum + 3 * n, 3); });
            grid.writtenBox(l) = box;
        }
    }
}

void Simulation::fetchNodes(const SparseGrid& grid, const std::vector<Vec3i>& nodes, std::vector<float>& mass,
                            std::vector<Vec3f>& velocity) {
    // Requests to each node's owner, answered in the order asked (mass 0 where the owner has no leaf: no
    // particle reaches there on any rank).
    const int R = comm_->size(), me = comm_->rank();
    std::vector<Bytes> ask(static_cast<std::size_t>(R));
    std::vector<std::vector<std::size_t>> asked(static_cast<std::size_t>(R));
    for (std::size_t i = 0; i < nodes.size(); ++i) {
        const int owner = ownerOf(leafOfNode(nodes[i]));
        putArray(ask[std::size_t(owner)], nodes[i].data(), 3);
        asked[std::size_t(owner)].push_back(i);
    }
    const std::vector<Bytes> questions = comm_->exchange(ask);
    const LeafLookup lookup(grid);
    std::vector<Bytes> answers(static_cast<std::size_t>(R));
    for (int r = 0; r < R; ++r) {
        if (r == me) continue;
        ByteReader q{questions[std::size_t(r)]};
        while (!q.done()) {
            Vec3i node;
            q.getArray(node.data(), 3);
            int offset = 0;
            const LeafView* leaf = lookup.at(node, nullptr, offset);
            const float m = leaf ? leaf->mass[offset] : 0.0f;
            const Vec3f v = leaf ? Vec3f(Eigen::Map<const Vec3f>(leaf->momentum + 3 * offset)) : Vec3f(Vec3f::Zero());
            put(answers[std::size_t(r)], m);
            putArray(answers[std::size_t(r)], v.data(), 3);
        }
    }
    const std::vector<Bytes> replies = comm_->exchange(answers);
    mass.assign(nodes.size(), 0.0f);
    velocity.assign(nodes.size(), Vec3f::Zero());
    for (int r = 0; r < R; ++r) {
        if (asked[std::size_t(r)].empty()) continue;
        ByteReader a{replies[std::size_t(r)]};
        for (std::size_t i : asked[std::size_t(r)]) {
            mass[i] = a.get<float>();
            a.getArray(velocity[i].data(), 3);
        }
    }
}

void Simulation::reduceSummary(G2PSummary& g2p) const {
    if (g2p.badParticle >= 0)
        g2p.badId = particlesOf(state_.species[std::size_t(g2p.badSpecies)]).id[std::size_t(g2p.badParticle)];
    if (!comm_->distributed()) return;
    g2p.maxSpeed = comm_->max(g2p.maxSpeed);
    comm_->min(g2p.minStiffnessKey);
    // One process reports the first bad particle in leaf order: on ranks, the lowest rank's first.
    const int reporter = comm_->firstRank(g2p.badParticle >= 0);
    if (reporter >= comm_->size()) return;
    Bytes b;
    if (comm_->rank() == reporter) {
        put(b, int32_t(g2p.badSpecies));
        put(b, g2p.badId);
        put(b, int32_t(std::string(g2p.badField) == "velocity" ? 0 : 1));
    }
    b = comm_->broadcast(b, reporter);
    ByteReader r{b};
    g2p.badSpecies = r.get<int32_t>();
    g2p.badId = r.get<int32_t>();
    g2p.badField = r.get<int32_t>() == 0 ? "velocity" : "deformation";
    if (comm_->rank() != reporter) g2p.badParticle = -2;  // held elsewhere: only the id is known here
}

std::vector<AnySpecies> Simulation::gatherSpecies() const {
    if (!comm_->distributed()) return state_.species;
    // One process holds the particles binned at the last substep in leaf order (the ranks' in rank order,
    // each in leaf order), then those emitted since, in id order: the ranks' latecomers are merged by id.
    std::vector<AnySpecies> out;
    for (const AnySpecies& s : state_.species)
        std::visit(
            [&](const auto& sp) {
                using S = std::decay_t<decltype(sp)>;
                const std::size_t binned = sp.leafStart.empty() ? 0 : std::min<std::size_t>(sp.leafStart.back(), sp.p.size());
                Bytes b;
                pack(sp, range(0, binned), b);
                pack(sp, range(binned, sp.p.size()), b);
                const std::vector<Bytes> all = comm_->gatherToRoot(b);
                S whole;
                whole.name = sp.name;
                whole.params = sp.params;
                whole.perParticle = sp.perParticle;
                if (comm_->rank() == 0) {
                    S late = whole;
                    for (const Bytes& rankBytes : all) {
                        ByteReader r{rankBytes};
                        unpackAppend(whole, r);
                        unpackAppend(late, r);
                    }
                    std::vector<uint32_t> order(late.p.size());
                    for (std::size_t i = 0; i < order.size(); ++i) order[i] = uint32_t(i);
                    std::stable_sort(order.begin(), order.end(),
                                     [&](uint32_t a, uint32_t c) { return late.p.id[a] < late.p.id[c]; });
                    late.forEachArray([&](auto& arr) {
                        std::decay_t<decltype(arr)> sorted;
                        sorted.reserve(arr.size());
                        for (uint32_t i : order) sorted.push_back(arr[i]);
                        arr.swap(sorted);
                    });
                    Bytes lateBytes;
                    pack(late, range(0, late.p.size()), lateBytes);
                    ByteReader r{lateBytes};
                    unpackAppend(whole, r);
                }
                out.emplace_back(std::move(whole));
            },
            s);
    return out;
}

SimState Simulation::gatherState() {
    SimState copy = state_.withoutParticles();
    copy.species = gatherSpecies();
    return copy;
}

}  // namespace mpm
