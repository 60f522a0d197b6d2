#pragma once
// Parallel work over the grid's leaves, through one small interface (as OpenVDB's LeafManager::foreach and
// reduce): a functor is called once per leaf index, tasks take `grain` consecutive leaves, and the grain
// for each kind of work is chosen here, once. Reductions are deterministic (a fixed split, joined in leaf
// order), so that a result never depends on the thread count.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_scan.h>

#include <cstddef>
#include <functional>

namespace mpm {

/// Leaves per task, by how much work one leaf is.
enum class LeafGrain : std::size_t {
    Particles = 1,     ///< a leaf's particles (hundreds of them in bulk): one leaf is work enough to balance
    Nodes = 16,        ///< a leaf's nodes (a grid update, a sum of halos): a few hundred operations each
    Bookkeeping = 256  ///< a few tree lookups or counters per leaf
};

/// Calls f(leaf) for leaf = 0 .. count - 1, in parallel.
template <class F>
void forEachLeaf(std::size_t count, LeafGrain grain, F&& f) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, std::size_t(grain)),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t l = r.begin(); l < r.end(); ++l) f(l);
                      });
}

/// As forEachLeaf, but f(begin, end) takes a task's whole range of leaves, for work that sets up something
/// per task (a tree accessor, a collider's context).
template <class F>
void forEachLeafRange(std::size_t count, LeafGrain grain, F&& f) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, std::size_t(grain)),
                      [&](const tbb::blocked_range<std::size_t>& r) { f(r.begin(), r.end()); });
}

/// Folds f(leaf, acc) over all leaves from `identity`, joining task results with join(a, b) in leaf order.
template <class T, class F, class J>
T reduceLeaves(std::size_t count, LeafGrain grain, T identity, F&& f, J&& join) {
    return tbb::parallel_deterministic_reduce(
        tbb::blocked_range<std::size_t>(0, count, std::size_t(grain)), identity,
        [&](const tbb::blocked_range<std::size_t>& r, T acc) {
            for (std::size_t l = r.begin(); l < r.end(); ++l) f(l, acc);
            return acc;
        },
        join);
}

/// As reduceLeaves, but f(begin, end, acc) takes a task's whole range of leaves (see forEachLeafRange).
template <class T, class F, class J>
T reduceLeafRanges(std::size_t count, LeafGrain grain, T identity, F&& f, J&& join) {
    return tbb::parallel_deterministic_reduce(
        tbb::blocked_range<std::size_t>(0, count, std::size_t(grain)), identity,
        [&](const tbb::blocked_range<std::size_t>& r, T acc) {
            f(r.begin(), r.end(), acc);
            return acc;
        },
        join);
}

/// Exclusive prefix sum over leaves: out(leaf, sum of size(k) for k < leaf); returns the total.
template <class T, class Size, class Out>
T prefixSumOverLeaves(std::size_t count, Size&& size, Out&& out) {
    return tbb::parallel_scan(
        tbb::blocked_range<std::size_t>(0, count, std::size_t(LeafGrain::Bookkeeping)), T(0),
        [&](const tbb::blocked_range<std::size_t>& r, T sum, bool final) {
            for (std::size_t l = r.begin(); l < r.end(); ++l) {
                if (final) out(l, sum);
                sum += size(l);
            }
            return sum;
        },
        std::plus<T>());
}

}  // namespace mpm
