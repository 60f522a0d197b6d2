#include "core/Comm.h"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>

#ifdef MPM_HAVE_MPI
// The C interface only: MPI's deprecated C++ bindings would pull their own library in.
#define OMPI_SKIP_MPICXX 1
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>
#endif

namespace mpm {

namespace {
Comm gWorld;
bool gStarted = false;
#ifdef MPM_HAVE_MPI
/// Calls of Comm::exchange so far: every rank makes them in the same order.
unsigned long long gExchanges = 0;
/// Comm::exchange's tags, kExchangeTag to kExchangeTag + 3 (gatherToRoot's are 1 and 2).
constexpr int kExchangeTag = 3;
#endif

/// Adds the seconds of a scope to a counter.
struct Timed {
    double& total;
    std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
    ~Timed() { total += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); }
};
}  // namespace

bool Comm::available() {
#ifdef MPM_HAVE_MPI
    return true;
#else
    return false;
#endif
}

Comm& Comm::world() { return gWorld; }

const Comm& Comm::single() {
    static const Comm one;
    return one;
}

#ifdef MPM_HAVE_MPI

/// Whether a launcher (mpirun, mpiexec, srun) started this process: OpenMPI and PMI/PMIx set these. Started
/// alone, the program does not initialise MPI: an MPI singleton costs about half a second of start-up.
bool launchedByMpi() {
    for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE", "PMI_RANK"})
        if (std::getenv(v)) return true;
    return false;
}

void Comm::start(int* argc, char*** argv) {
    if (!launchedByMpi()) return;
    int provided = 0;
    // Only the main thread calls MPI; the threads of a rank (oneTBB) never do.
    MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
    gStarted = true;
    MPI_Comm_rank(MPI_COMM_WORLD, &gWorld.rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &gWorld.size_);
}

void Comm::finish() {
    if (gStarted) MPI_Finalize();
    gStarted = false;
}

float Comm::max(float x) const {
    if (!distributed()) return x;
    Timed t{seconds_};
    MPI_Allreduce(MPI_IN_PLACE, &x, 1, MPI_FLOAT, MPI_MAX, MPI_COMM_WORLD);
    return x;
}
double Comm::max(double x) const {
    if (!distributed()) return x;
    Timed t{seconds_};
    MPI_Allreduce(MPI_IN_PLACE, &x, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    return x;
}
double Comm::min(double x) const {
    if (!distributed()) return x;
    Timed t{seconds_};
    MPI_Allreduce(MPI_IN_PLACE, &x, 1, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
    return x;
}
void Comm::min(std::vector<float>& x) const {
    if (!distributed() || x.empty()) return;
    Timed t{seconds_};
    MPI_Allreduce(MPI_IN_PLACE, x.data(), int(x.size()), MPI_FLOAT, MPI_MIN, MPI_COMM_WORLD);
}
long long Comm::sum(long long x) const {
    if (!distributed()) return x;
    Timed t{seconds_};
    MPI_Allreduce(MPI_IN_PLACE, &x, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    return x;
}
void Comm::sum(ExactSum& s) const {
    if (!distributed()) return;
    Timed t{seconds_};
    // Normalised digits are below 2^32 and the top limb is signed: integer sums of up to 2^31 ranks are exact.
    s.normalise();
    MPI_Allreduce(MPI_IN_PLACE, s.limbs(), ExactSum::kLimbs, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
    MPI_Allreduce(MPI_IN_PLACE, &s.special(), 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    s.normalise();
}
int Comm::firstRank(bool mine) const {
    if (!distributed()) return mine ? 0 : 1;
    Timed t{seconds_};
    int r = mine ? rank_ : size_;
    MPI_Allreduce(MPI_IN_PLACE, &r, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    return r;
}
Bytes Comm::broadcast(Bytes b, int root) const {
    if (!distributed()) return b;
    Timed t{seconds_};
    unsigned long long n = b.size();
    MPI_Bcast(&n, 1, MPI_UNSIGNED_LONG_LONG, root, MPI_COMM_WORLD);
    b.resize(n);
    MPI_Bcast(b.data(), int(n), MPI_BYTE, root, MPI_COMM_WORLD);
    return b;
}
std::vector<Bytes> Comm::allGather(const Bytes& mine) const {
    if (!distributed()) return {mine};
    Timed t{seconds_};
    std::vector<int> sizes(size_), offsets(size_);
    int n = int(mine.size());
    MPI_Allgather(&n, 1, MPI_INT, sizes.data(), 1, MPI_INT, MPI_COMM_WORLD);
    int total = 0;
    for (int r = 0; r < size_; ++r) offsets[r] = total, total += sizes[r];
    Bytes all(std::size_t(total) + 1);
    MPI_Allgatherv(mine.data(), n, MPI_BYTE, all.data(), sizes.data(), offsets.data(), MPI_BYTE, MPI_COMM_WORLD);
    std::vector<Bytes> out(size_);
    for (int r = 0; r < size_; ++r) out[r].assign(all.begin() + offsets[r], all.begin() + offsets[r] + sizes[r]);
    return out;
}
std::vector<Bytes> Comm::gatherToRoot(const Bytes& mine) const {
    if (!distributed()) return {mine};
    Timed t{seconds_};
    // Point to point, rank by rank: a frame's particles can pass the 2 GiB an int count allows in one gatherv.
    std::vector<Bytes> out;
    if (rank_ == 0) {
        out.resize(size_);
        out[0] = mine;
        for (int r = 1; r < size_; ++r) {
            unsigned long long n = 0;
            MPI_Recv(&n, 1, MPI_UNSIGNED_LONG_LONG, r, 1, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            out[r].resize(n);
            for (unsigned long long at = 0; at < n;) {
                const int piece = int(std::min<unsigned long long>(n - at, 1u << 30));
                MPI_Recv(out[r].data() + at, piece, MPI_BYTE, r, 2, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
                at += unsigned(piece);
            }
        }
    } else {
        unsigned long long n = mine.size();
        MPI_Send(&n, 1, MPI_UNSIGNED_LONG_LONG, 0, 1, MPI_COMM_WORLD);
        for (unsigned long long at = 0; at < n;) {
            const int piece = int(std::min<unsigned long long>(n - at, 1u << 30));
            MPI_Send(mine.data() + at, piece, MPI_BYTE, 0, 2, MPI_COMM_WORLD);
            at += unsigned(piece);
        }
    }
    return out;
}
std::vector<Bytes> Comm::exchange(const std::vector<Bytes>& out) const {
    if (!distributed()) return {out.at(0)};
    Timed t{seconds_};
    // Sparse exchange without a neighbour list (NBX, Hoefler et al. 2010): each rank sends, synchronously, only to
    // the ranks it has bytes for, and receives whatever arrives until every rank has seen its own sends received;
    // a non-blocking barrier tells when that is. Sizes and bytes pass between neighbours only, and nobody needs
    // to know beforehand who its neighbours are (a leaf can appear anywhere: emission, migration, a re-cut).
    // Calls alternate between two pairs of tags: a rank that has left a call can send the next call's first
    // message to a rank still waiting on the barrier of this one, never one of the call after.
    const int parity = int(gExchanges++ % 2);
    const int sizeTag = kExchangeTag + parity, pieceTag = kExchangeTag + 2 + parity;
    // Pieces of at most kPiece bytes (an MPI count is an int); messages of one sender and tag arrive in order.
    constexpr unsigned long long kPiece = 1ull << 30;
    std::vector<unsigned long long> sendSize(size_);
    std::vector<MPI_Request> sends, receives;
    for (int r = 0; r < size_; ++r) {
        sendSize[r] = out[r].size();
        if (r == rank_ || sendSize[r] == 0) continue;
        sends.emplace_back();
        MPI_Issend(&sendSize[r], 1, MPI_UNSIGNED_LONG_LONG, r, sizeTag, MPI_COMM_WORLD, &sends.back());
        for (unsigned long long at = 0; at < sendSize[r]; at += kPiece) {
            sends.emplace_back();
            MPI_Issend(out[r].data() + at, int(std::min(kPiece, sendSize[r] - at)), MPI_BYTE, r, pieceTag, MPI_COMM_WORLD,
                       &sends.back());
        }
        bytesSent_ += sendSize[r];
    }
    std::vector<Bytes> in(size_);
    in[rank_] = out[rank_];
    MPI_Request barrier = MPI_REQUEST_NULL;
    for (bool allSent = false;;) {
        int arrived = 0;
        MPI_Status status;
        MPI_Iprobe(MPI_ANY_SOURCE, sizeTag, MPI_COMM_WORLD, &arrived, &status);
        if (arrived) {
            const int from = status.MPI_SOURCE;
            unsigned long long n = 0;
            MPI_Recv(&n, 1, MPI_UNSIGNED_LONG_LONG, from, sizeTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            in[from].resize(n);
            for (unsigned long long at = 0; at < n; at += kPiece) {
                receives.emplace_back();
                MPI_Irecv(in[from].data() + at, int(std::min(kPiece, n - at)), MPI_BYTE, from, pieceTag, MPI_COMM_WORLD,
                          &receives.back());
            }
            continue;
        }
        if (allSent) {
            int done = 0;
            MPI_Test(&barrier, &done, MPI_STATUS_IGNORE);
            if (done) break;
        } else {
            int done = 0;
            MPI_Testall(int(sends.size()), sends.data(), &done, MPI_STATUSES_IGNORE);
            if (done) MPI_Ibarrier(MPI_COMM_WORLD, &barrier), allSent = true;
        }
    }
    MPI_Waitall(int(receives.size()), receives.data(), MPI_STATUSES_IGNORE);
    return in;
}
void Comm::abort(int code) const {
    if (gStarted) MPI_Abort(MPI_COMM_WORLD, code);
    std::_Exit(code);
}

#else  // one process

void Comm::start(int*, char***) { gStarted = true; }
void Comm::finish() { gStarted = false; }
float Comm::max(float x) const { return x; }
double Comm::max(double x) const { return x; }
double Comm::min(double x) const { return x; }
void Comm::min(std::vector<float>&) const {}
long long Comm::sum(long long x) const { return x; }
void Comm::sum(ExactSum&) const {}
int Comm::firstRank(bool mine) const { return mine ? 0 : 1; }
Bytes Comm::broadcast(Bytes b, int) const { return b; }
std::vector<Bytes> Comm::allGather(const Bytes& mine) const { return {mine}; }
std::vector<Bytes> Comm::gatherToRoot(const Bytes& mine) const { return {mine}; }
std::vector<Bytes> Comm::exchange(const std::vector<Bytes>& out) const { return {out.at(0)}; }
void Comm::abort(int code) const { std::_Exit(code); }

#endif

}  // namespace mpm
