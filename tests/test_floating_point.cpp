// The floating-point mode the engine runs in (core/FloatingPoint.h).
#include <gtest/gtest.h>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <atomic>

#include "core/FloatingPoint.h"

namespace {
/// How many of many small tasks ran without subnormals flushed (by the mode bits, and by a product below
/// float's smallest normal that must come out as zero).
int unflushedTasks(int& tasks) {
    std::atomic<int> unflushed{0}, count{0};
    tbb::parallel_for(tbb::blocked_range<int>(0, 4096, 1), [&](const tbb::blocked_range<int>&) {
        ++count;
        volatile float tiny = 1e-30f, scale = 1e-15f;
        if (!mpm::denormalsFlushed() || tiny * scale != 0.0f) ++unflushed;
    });
    tasks = count.load();
    return unflushed.load();
}
}  // namespace

TEST(FloatingPoint, EngineWorkRunsWithSubnormalsFlushedInEveryThreadAndOnlyThere) {
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 4);
    int tasks = 0;
    // Workers busy elsewhere first: they are flushed as they enter the engine's arena, whenever that is.
    tbb::parallel_for(0, 4096, [](int) {});
    EXPECT_EQ(mpm::withSubnormalsFlushed([&] { return unflushedTasks(tasks); }), 0);
    EXPECT_GT(tasks, 1);
    for (int again = 0; again < 3; ++again) EXPECT_EQ(mpm::withSubnormalsFlushed([&] { return unflushedTasks(tasks); }), 0);
    // Outside the engine every thread keeps its own mode, the caller's included.
    EXPECT_FALSE(mpm::denormalsFlushed());
    EXPECT_EQ(unflushedTasks(tasks), tasks);
}
