#pragma once
// Subnormal floats off in every thread that runs the engine. Once a scene settles, velocities and stress
// increments decay towards zero and pass through the subnormal range, where many x86 CPUs (Intel's among them)
// take a microcode assist on every operation: a million-particle block settling on a floor ran 8.6x slower (water)
// and 5.5x (jelly) on a 2-core Xeon with AVX-512 (an AMD EPYC shows no such cliff: 1.7e7 particle-substeps a
// second over 15 and over 200 substeps). With flush-to-zero (results that would be subnormal become 0) and
// denormals-are-zero (subnormal inputs read as 0) those operations run at full speed.
//
// oneTBB runs every task with the floating-point settings its task group context captured, and a context not
// told otherwise inherits its parent's, back to the calling thread's default context, made when that thread first
// used TBB: setting the mode in the calling thread alone changes no task. So the engine's work runs as a task of a
// context that captures the flushing mode: every task under it, on any thread, flushes alike (results stay the same
// for any thread count), and work outside the engine (OpenVDB's surfacing, the Python caller's numpy) keeps the
// mode it always had.
#include <tbb/task_group.h>

#include <optional>
#include <type_traits>

namespace mpm {

/// Turns FTZ and DAZ on for the calling thread while it lives, and restores the thread's mode after.
class DenormalsFlushed {
public:
    DenormalsFlushed();
    ~DenormalsFlushed();
    DenormalsFlushed(const DenormalsFlushed&) = delete;
    DenormalsFlushed& operator=(const DenormalsFlushed&) = delete;

private:
    unsigned saved_ = 0;
};

/// Runs f as a task of a context that captured the flushing mode, so that every parallel algorithm f starts runs
/// its tasks with subnormals flushed; returns f's result, rethrows what it throws. run_and_wait executes f on the
/// calling thread itself (it is not spawned, so no worker can take it): MPI calls in f stay on the rank's thread.
template <class F>
auto withSubnormalsFlushed(F&& f) {
    const DenormalsFlushed flushed;
    tbb::task_group_context context(tbb::task_group_context::bound,
                                    tbb::task_group_context::default_traits | tbb::task_group_context::fp_settings);
    tbb::task_group group(context);
    if constexpr (std::is_void_v<decltype(f())>) {
        group.run_and_wait([&] { f(); });
    } else {
        std::optional<decltype(f())> result;
        group.run_and_wait([&] { result.emplace(f()); });
        return std::move(*result);
    }
}

/// Whether the calling thread flushes subnormals (FTZ and DAZ both on); true where the CPU has no such mode
/// to set (not x86).
bool denormalsFlushed();

}  // namespace mpm
