#pragma once
// The processes of a run and what they exchange (MPI; docs/distributed.md). Without MPI, or started
// without mpirun, there is one process and every call here is the identity. Only this interface is seen by
// the engine: mpi.h stays in core/Comm.cpp. Every call is collective (all ranks make it, in the same order)
// and is made from the main thread only.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "core/ExactSum.h"

namespace mpm {

using Bytes = std::vector<std::byte>;

class Comm {
public:
    /// Starts MPI when the program was built with it (and was launched by mpirun, or alone: a singleton
    /// run is one rank). Call once, first thing in main; finish() at the end.
    static void start(int* argc, char*** argv);
    static void finish();
    /// The processes of this run (one, when MPI is absent or not started).
    static Comm& world();
    /// A communicator of this process alone (what a Simulation uses until it is distributed).
    static const Comm& single();
    /// Whether this build has MPI at all.
    static bool available();

    int rank() const { return rank_; }
    int size() const { return size_; }
    bool distributed() const { return size_ > 1; }

    float max(float x) const;
    double max(double x) const;
    double min(double x) const;
    void min(std::vector<float>& x) const;  ///< element by element
    long long sum(long long x) const;
    /// The exact sum over ranks: the same bits as one process summing every term (core/ExactSum.h).
    void sum(ExactSum& s) const;
    /// The lowest rank for which `mine` is true, or size() when none.
    int firstRank(bool mine) const;
    /// Rank `root`'s bytes, on every rank.
    Bytes broadcast(Bytes b, int root) const;
    /// Every rank's bytes, in rank order, on every rank.
    std::vector<Bytes> allGather(const Bytes& mine) const;
    /// Every rank's bytes on rank 0 (empty elsewhere), in rank order.
    std::vector<Bytes> gatherToRoot(const Bytes& mine) const;
    /// out[r] goes to rank r; returns what each rank sent here. Sizes and payloads pass only between ranks that
    /// have something for each other (point to point), and a non-blocking barrier ends the exchange.
    std::vector<Bytes> exchange(const std::vector<Bytes>& out) const;
    /// Ends every rank at once with this exit code (a failure that only one rank saw).
    [[noreturn]] void abort(int code) const;

    /// Bytes this rank sent in exchange() since the last reset (the scaling benchmark reports them).
    std::size_t bytesSent() const { return bytesSent_; }
    double secondsCommunicating() const { return seconds_; }
    void resetCounters() { bytesSent_ = 0, seconds_ = 0.0; }

private:
    int rank_ = 0, size_ = 1;
    mutable std::size_t bytesSent_ = 0;
    mutable double seconds_ = 0.0;
};

/// A plain value or array appended to / read from a byte buffer (exchange payloads).
template <class T>
void put(Bytes& b, const T& v) {
    const std::size_t n = b.size();
    b.resize(n + sizeof(T));
    std::memcpy(b.data() + n, &v, sizeof(T));
}
template <class T>
void putArray(Bytes& b, const T* p, std::size_t count) {
    const std::size_t n = b.size();
    b.resize(n + count * sizeof(T));
    if (count) std::memcpy(b.data() + n, p, count * sizeof(T));
}
/// Reads back what put/putArray wrote, in order.
struct ByteReader {
    const Bytes& b;
    std::size_t at = 0;
    template <class T>
    T get() {
        T v;
        std::memcpy(static_cast<void*>(&v), b.data() + at, sizeof(T));
        at += sizeof(T);
        return v;
    }
    template <class T>
    void getArray(T* p, std::size_t count) {
        if (count) std::memcpy(static_cast<void*>(p), b.data() + at, count * sizeof(T));
        at += count * sizeof(T);
    }
    bool done() const { return at >= b.size(); }
};

}  // namespace mpm
