#include "io/Run.h"

#include <unistd.h>
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <regex>
#include <sstream>

#include "io/AtomicFile.h"
#include "io/Checkpoint.h"
#include "io/SceneBudget.h"
#include "io/SceneReader.h"

#ifndef MPM_VERSION
#define MPM_VERSION "unknown"
#endif

namespace fs = std::filesystem;

namespace mpm {

namespace {

std::string regexEscape(const std::string& s) { return std::regex_replace(s, std::regex(R"([.^$|()\[\]{}*+?\\])"), R"(\$&)"); }

/// Exactly this scene's frame files: <scene>_NNNN.vdb|ply and <scene>_points_NNNN.vdb, nothing of a scene
/// whose name merely starts with this one's (a scene "dam" does not own "dam_break_0004.vdb").
std::regex framesOf(const std::string& scene) {
    return std::regex("^" + regexEscape(scene) + R"(_(points_)?[0-9]{4,}(_rank[0-9]{3,})?\.(vdb|ply)$)");
}
std::regex checkpointsOf(const std::string& scene) {
    return std::regex("^" + regexEscape(scene) + R"(_checkpoint_[0-9]{4,}(_inside)?(_rank[0-9]{3,})?\.mpmc$)");
}
/// The temporary files this program writes, of any scene (one run per directory: none is in use now).
const std::regex kTemporary(
    R"(^(.+_(points_|checkpoint_)?[0-9]{4,}(_inside)?(_rank[0-9]{3,})?\.(vdb|ply|mpmc)|stats\.csv|bodies\.csv|scene\.json)\.tmp[0-9]+$)");

/// Runs fn on the ranks where `here` is true and has every rank throw what the first of them to fail threw,
/// as the same kind of error, so that all of them stop together and one of them reports it.
template <class F>
void agreeOnFailure(const Comm& comm, bool here, F&& fn) {
    if (!comm.distributed()) {
        fn();
        return;
    }
    enum Kind : int32_t { kNone, kScene, kLock, kWrite, kLimit, kOther };
    int32_t kind = kNone;
    std::string what, path;
    std::exception_ptr error;
    if (here) try {
            fn();
        } catch (const SceneError& e) {
            kind = kScene, what = e.what(), error = std::current_exception();
        } catch (const LockError& e) {
            kind = kLock, what = e.what(), error = std::current_exception();
        } catch (const WriteError& e) {
            kind = kWrite, what = e.what(), path = e.path(), error = std::current_exception();
        } catch (const LimitExceeded& e) {
            kind = kLimit, what = e.what(), error = std::current_exception();
        } catch (const std::exception& e) {
            kind = kOther, what = e.what(), error = std::current_exception();
        }
    const int reporter = comm.firstRank(kind != kNone);
    if (reporter >= comm.size()) return;
    Bytes b;
    if (comm.rank() == reporter) {
        put(b, kind);
        put(b, uint64_t(path.size()));
        putArray(b, path.data(), path.size());
        putArray(b, what.data(), what.size());
    }
    b = comm.broadcast(b, reporter);
    ByteReader r{b};
    kind = r.get<int32_t>();
    path.resize(r.get<uint64_t>());
    r.getArray(path.data(), path.size());
    what.assign(reinterpret_cast<const char*>(b.data()) + r.at, b.size() - r.at);
    if (error && comm.rank() == reporter) std::rethrow_exception(error);
    switch (kind) {
        case kScene:
            throw SceneError(what);
        case kLock:
            throw LockError(what);
        case kWrite:
            throw WriteError(path, what.size() > path.size() + 2 ? what.substr(path.size() + 2) : what);
        case kLimit:
            throw LimitExceeded(what);
        default:
            throw std::runtime_error(what);
    }
}

/// What the lowest rank whose `error` is not empty says (empty when no rank's is): every rank gets it.
std::string firstError(const Comm& comm, const std::string& error) {
    const int reporter = comm.firstRank(!error.empty());
    if (reporter >= comm.size()) return std::string();
    Bytes b;
    if (comm.rank() == reporter) putArray(b, error.data(), error.size());
    b = comm.broadcast(b, reporter);
    return std::string(reinterpret_cast<const char*>(b.data()), b.size());
}

/// A text file's content; empty when it cannot be read (a run's first stats.csv).
std::string readTextFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/// The identity of a checkpoint's scene as this version reads it: its scene read again, so that keys added to the
/// format since it was written come in at their defaults. A key is added with the default that keeps what the engine
/// did before it, so a checkpoint whose scene differs only by such keys is of this scene, and resumes. A scene this
/// version no longer reads keeps its identity as stored (and differs).
std::string identityToday(const std::string& stored, const std::string& file) {
    try {
        return sceneIdentity(parseScene(stored, file).resolvedJson);
    } catch (const SceneError&) {
        return stored;
    }
}

/// Rank 0 alone: the output directory is its to write.
template <class F>
void onRoot(const Comm& comm, F&& fn) {
    agreeOnFailure(comm, comm.rank() == 0, fn);
}

}  // namespace

SceneRun::SceneRun(const std::string& scenePath, RunOptions options, RunEvents events)
    : scene_(loadScene(scenePath)), options_(std::move(options)), events_(std::move(events)) {
    // Budgets before work: a scene that cannot run here fails now, with the estimate and what to change.
    const SceneBudget budget = estimateBudget(scene_, false, Comm::world().size());
    checkBudget(scene_, budget);
    neededBytes_ = budget.memoryBytes, machineBytes_ = budget.machineBytes, machineHolder_ = budget.machineHolder;
    last_ = options_.lastFrame < 0 ? scene_.frames : options_.lastFrame;
    // Files are counted from 1; 0 names the initial state, whose file output.initial_frame writes.
    if (options_.framesGiven && (last_ > scene_.frames || options_.firstFrame > scene_.frames))
        throw SceneError(
            scene_.file + ": --frames " + std::to_string(options_.firstFrame) + ":" + std::to_string(last_) + ": the scene has " +
            std::to_string(scene_.frames) +
            " frames (simulation.frames); ask for frames within 1:" + std::to_string(scene_.frames) +
            " (or from 0, the initial state, written when output.initial_frame is true), or raise simulation.frames");
    dir_ = options_.outDir.empty() ? scene_.output.directory : options_.outDir;
    // On several ranks (mpirun) rank 0 alone owns the directory: it takes the lock and writes every file.
    const Comm& comm = Comm::world();
    onRoot(comm, [&] {
        std::error_code ec;
        fs::create_directories(dir_, ec);
        if (ec) throw SceneError(dir_ + ": cannot create the output directory: " + ec.message() + "; choose another with -o");
        refuseNamesTooLong();
        lock_ = std::make_unique<DirectoryLock>(dir_);
        if (!lock_->takenOverFrom().empty())
            events_.warning("took over the lock of " + dir_ + " from a run that is gone (" + lock_->takenOverFrom() + ")");
        refuseAnotherScenesDirectory();
        removeStaleTemporaries();
        // --resume with no checkpoint file at all says so now, not after sampling the sets (17 s for 0.9M particles);
        // whether a file is usable (whole, of this scene) is known only once the scene is built.
        if (options_.resume && !anyCheckpointToResume()) throw SceneError(nothingToResume());
    });
    DerivedValues derived;
    std::string phase = "reading the scene";
    SetupWatch watch;
    watch.note = [&](const std::string& what) {
        phase = what;
        events_.note(what);
    };
    watch.report = [&](const std::string& what) { events_.note(what); };
    if (!comm.distributed()) watch.stop = events_.stop;
    try {
        guarded("sampling the particle sets", [&] { sim_ = buildSimulation(scene_, Comm::world(), &derived, watch); });
        if (watch.stop && watch.stop->load() != 0) throw Interrupted();
    } catch (const Interrupted&) {
        throw SetupInterrupted(phase);
    }
    for (const std::string& w : summarisedWarnings(derived.warnings)) events_.warning(w);
    // From here the scene is the one that runs: every default stated, the pivots the builder derived included.
    scene_.resolvedJson = resolvedWithDerived(scene_, derived);
    long long dueAtStart = 0;  // of the samples held here: those of the sets emitted at frame 0
    for (const Emitter& e : sim_->emitters()) {
        heldSamples_ += (long long)e.positions.size();
        setSamples_ += e.holdsPart() ? e.total : (long long)e.positions.size();
        if (e.emitsAt(0)) dueAtStart += (long long)e.positions.size();
    }
    layout_ = speciesLayout(scene_);
    identity_ = sceneIdentity(scene_.resolvedJson);
    hash_ = sceneHash(identity_);
    const std::string starting = options_.resume ? "reading the newest usable checkpoint of " + dir_
                                 : options_.framesGiven
                                     ? "reading the newest checkpoint before frame " + std::to_string(options_.firstFrame) +
                                           " of " + dir_ + ", or else emitting the sets due at the start"
                                     : "emitting the sets due at the start";
    events_.note(starting + " (" + std::to_string(dueAtStart) + " particles" +
                 (dueAtStart == heldSamples_
                      ? std::string()
                      : "; " + std::to_string(heldSamples_ - dueAtStart) + " more sampled for the sets due later") +
                 ")");
    guarded(starting, [&] { chooseStart(); });
    onRoot(comm, [&] {
        // Part of a scene (--frames A:B): the rows of the other frames stay as the earlier runs wrote them.
        std::map<int, std::string> kept;
        if (options_.framesGiven)
            for (auto& [frame, row] : statsRows(readTextFile(dir_ + "/stats.csv")))
                if (frame < options_.firstFrame || frame > last_) kept[frame] = std::move(row);
        writer_ = std::make_unique<FrameWriter>(scene_, layout_, dir_, statsSoFar_, std::move(kept));
    });
    if (comm.distributed() && scene_.output.rankFiles == "per_rank")
        partWriter_ = std::make_unique<FrameWriter>(FrameWriter::partWriter(scene_, layout_, dir_, comm.rank()));
    // The initial state's row (and file 0, if asked for), once: a run restored inside frame 1 has it in its stats.
    if (start_ == 0 && !restored_)
        guarded("writing frame 0",
                [&] { writeFrame(0, sim_->measure(), options_.firstFrame == 0 && scene_.output.initialFrame); });
}

void SceneRun::writeFrame(int frame, const FrameStats& st, bool write) {
    const Comm& comm = Comm::world();
    if (!comm.distributed()) {
        if (write)
            writer_->writeFrame(frame, *sim_, st);
        else
            writer_->recordStats(st);
        return;
    }
    if (partWriter_) {
        // Every rank its own part files; a write that fails on one stops all of them.
        if (write) agreeOnFailure(comm, true, [&] { partWriter_->writeFrame(frame, sim_->species(), sim_->settings().dx, st); });
        onRoot(comm, [&] { writer_->recordStats(st); });
        return;
    }
    const std::vector<AnySpecies> all = write ? sim_->gatherSpecies() : std::vector<AnySpecies>{};
    onRoot(comm, [&] {
        if (write)
            writer_->writeFrame(frame, all, sim_->settings().dx, st);
        else
            writer_->recordStats(st);
    });
}

SceneRun::~SceneRun() = default;

template <class F>
void SceneRun::guarded(const std::string& what, F&& f) {
    try {
        f();
    } catch (const std::bad_alloc&) {
        const Comm& comm = Comm::world();
        if (comm.distributed()) {  // this rank alone ran out: the others cannot be told, so all stop now
            std::fprintf(stderr, "error: rank %d of %d ran out of memory while %s with %zu particles\n", comm.rank(), comm.size(),
                         what.c_str(), sim_ ? sim_->particleCount() : std::size_t(0));
            comm.abort(1);
        }
        std::ostringstream msg;
        msg.precision(3);
        msg << "out of memory while " << what << " with " << (sim_ ? sim_->particleCount() : 0)
            << " particles (the scene needs about " << neededBytes_ / double(1u << 30)
            << " GiB at its peak by validate's estimate; " << machineHolder_ << " " << machineBytes_ / double(1u << 30)
            << " GiB, less what other programs and the process's limits (ulimit -v) leave)";
        throw LimitExceeded(msg.str());
    }
}

void SceneRun::refuseNamesTooLong() const {
    // The longest name a run writes: a checkpoint part's, with its frame's digits and the atomic write's temporary
    // suffix (<scene>_checkpoint_NNNN_inside_rankRRR.mpmc.tmpPID). Found now, not at the first frame's write minutes
    // later.
    constexpr std::size_t kPidDigits = 10;
    const std::size_t frameDigits = std::max<std::size_t>(4, std::to_string(scene_.frames).size());
    const std::size_t longest =
        scene_.name.size() + std::strlen("_checkpoint_") + frameDigits + std::strlen("_inside_rank000.mpmc.tmp") + kPidDigits;
    const long limit = ::pathconf(dir_.c_str(), _PC_NAME_MAX);
    if (limit > 0 && longest > std::size_t(limit))
        throw SceneError(scene_.file + ": the scene's name (its file's, " + std::to_string(scene_.name.size()) +
                         " characters) makes file names of up to " + std::to_string(longest) + " characters, and " + dir_ +
                         " takes " + std::to_string(limit) +
                         ": give the scene file a shorter name (its frames are named after it)");
}

void SceneRun::refuseAnotherScenesDirectory() const {
    // Scene names can extend one another (dam, dam_points: dam's split points files are named as dam_points's
    // frames), and stats.csv and scene.json are the directory's: two scenes cannot share one without one touching
    // the other's files. The scene.json of the run before says whose the directory is.
    const std::string record = dir_ + "/scene.json";
    std::error_code ec;
    if (!fs::exists(record, ec)) return;
    std::string owner;
    try {
        owner = fs::path(nlohmann::json::parse(readTextFile(record)).value("scene_file", std::string())).stem().string();
    } catch (const std::exception&) {
        return;  // not a record of ours: nothing of a scene to protect
    }
    if (owner.empty() || owner == scene_.name) return;
    throw SceneError(
        dir_ + ": holds the frames of scene \"" + owner + "\" (its scene.json); an output directory holds one scene's " +
        "frames, stats.csv, bodies.csv and scene.json: give scene \"" + scene_.name + "\" a directory of its own with -o");
}

void SceneRun::removeStaleTemporaries() {
    int removed = 0;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir_, ec))
        if (e.is_regular_file() && std::regex_match(e.path().filename().string(), kTemporary) && fs::remove(e.path(), ec))
            ++removed;
    if (removed) events_.note("removed " + std::to_string(removed) + " temporary files of an earlier run that was stopped");
}

void SceneRun::removeOldOutputs() {
    const std::regex frames = framesOf(scene_.name), checkpoints = checkpointsOf(scene_.name);
    int removed = 0;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir_, ec)) {
        const std::string name = e.path().filename().string();
        if (e.is_regular_file() && (std::regex_match(name, frames) || std::regex_match(name, checkpoints)) &&
            fs::remove(e.path(), ec))
            ++removed;
    }
    // An earlier run's rigid bodies: this run writes its own bodies.csv, or none when the scene has no body.
    if (std::none_of(scene_.colliders.begin(), scene_.colliders.end(), [](const ColliderDesc& c) { return c.dynamic.enabled; }) &&
        fs::remove(dir_ + "/bodies.csv", ec))
        ++removed;
    if (removed)
        events_.note("removed " + std::to_string(removed) + " frame and checkpoint files of an earlier run of this scene");
}

void SceneRun::spread() { sim_->distribute(Comm::world()); }

void SceneRun::chooseStart() {
    // On several ranks the leaves are cut before the first emission (each rank keeps its share of the sets
    // as they are emitted) or after a checkpoint is read (every rank reads a whole one and keeps its share, or
    // reads some of a set's parts and sends on what other ranks own).
    if (!options_.resume && !options_.framesGiven) {
        onRoot(Comm::world(), [&] { removeOldOutputs(); });
        spread();
        sim_->emitDue();
        return;
    }
    // The newest checkpoint that can produce the first frame asked for, valid and of this scene.
    const int newest = options_.framesGiven ? options_.firstFrame - 1 : std::numeric_limits<int>::max();
    for (const CheckpointFiles& files : listCheckpoints(dir_, scene_.name)) {
        if (files.frame > newest) continue;
        Checkpoint c;
        bool share = false;
        std::string path;
        if (!readCheckpointOf(files, c, share, path)) continue;
        const std::string before = c.info.sceneHash == hash_ ? identity_ : identityToday(c.info.sceneJson, scene_.file);
        if (before != identity_) {
            std::string changes;
            for (const std::string& d : sceneDifferences(before, identity_)) changes += (changes.empty() ? "" : "; ") + d;
            if (options_.resume && !options_.force)
                throw SceneError(scene_.file + ": the scene changed since " + path + " was written (" + changes +
                                 "); run without --resume to start over, or add --force to resume anyway");
            if (!options_.force) {
                events_.warning("not starting from " + path + ": written for another version of the scene (" + changes + ")");
                continue;
            }
            events_.warning("resuming from " + path + " although the scene changed (" + changes + ")");
        }
        try {
            sim_->restore(std::move(c.state), share);
        } catch (const std::invalid_argument& e) {
            throw SceneError(scene_.file + ": " + path + " cannot continue this scene: " + e.what());
        }
        spread();
        statsSoFar_ = c.info.statsCsv;
        start_ = c.info.frame;
        restored_ = true;
        events_.note("continuing from " + path + " (" +
                     (c.info.midFrame ? "inside frame " + std::to_string(start_ + 1) : "after frame " + std::to_string(start_)) +
                     ", t = " + std::to_string(c.info.time) + " s)");
        return;
    }
    if (options_.resume) throw SceneError(nothingToResume());
    spread();
    sim_->emitDue();  // --frames without a checkpoint: simulate from frame 0, write only the frames asked for
}

bool SceneRun::anyCheckpointToResume() const {
    const int newest = options_.framesGiven ? options_.firstFrame - 1 : std::numeric_limits<int>::max();
    const std::vector<CheckpointFiles> files = listCheckpoints(dir_, scene_.name);
    return std::any_of(files.begin(), files.end(), [&](const CheckpointFiles& f) { return f.frame <= newest; });
}

std::string SceneRun::nothingToResume() const {
    return dir_ + ": no usable checkpoint of scene " + scene_.name +
           (options_.framesGiven ? " before frame " + std::to_string(options_.firstFrame) : std::string()) +
           " to resume from; run without --resume to start from frame 0";
}

bool SceneRun::readCheckpointOf(const CheckpointFiles& files, Checkpoint& c, bool& share, std::string& path) {
    const Comm& comm = Comm::world();
    // Runs a read on every rank; what the first rank to fail says, every rank gets (empty: none failed).
    const auto agreed = [&](auto&& read) {
        std::string error;
        try {
            read();
        } catch (const CheckpointError& e) {
            error = e.what();
        }
        return firstError(comm, error);
    };
    if (!files.whole.empty()) {
        // A whole checkpoint: every rank reads it and keeps its share (distribute).
        path = files.whole;
        const std::string error = agreed([&] { c = readCheckpoint(path); });
        if (error.empty()) return true;
        events_.warning(error + (files.parts.empty() ? "; trying the one before" : "; trying its parts"));
        if (files.parts.empty()) return false;
    }
    // Parts of a set: rank r of M reads parts k with k M / N = r (all of them alone, none when M > N), then
    // the particles go to their owners (distribute); a rank without a part takes the scalars from rank 0.
    std::vector<std::string> paths;
    bool first = true;
    const std::string setError = agreed([&] { paths = completeSet(files); });
    const std::string partError = setError.empty() ? agreed([&] {
        const long long N = (long long)paths.size(), M = comm.size();
        for (long long k = 0; k < N; ++k) {
            if (k * M / N != comm.rank()) continue;
            Checkpoint part = readCheckpoint(paths[std::size_t(k)]);
            if (first)
                c = std::move(part), first = false;
            else
                appendSpecies(c.state, std::move(part.state));
        }
    })
                                                   : setError;
    if (!partError.empty()) {
        events_.warning(partError + "; trying the one before");
        return false;
    }
    path = checkpointPartPath(dir_, scene_.name, files.frame, -1, files.inside);
    if (comm.distributed()) {
        // Ranks that read no part (more ranks than parts) need the run's scalars and species, without particles.
        Bytes skeleton;
        if (comm.rank() == 0) {
            std::ostringstream os;
            encodeCheckpoint(os, c.info, c.state.withoutParticles());
            const std::string bytes = os.str();
            putArray(skeleton, bytes.data(), bytes.size());
        }
        skeleton = comm.broadcast(skeleton, 0);
        if (first)
            c = decodeCheckpoint(std::vector<char>(reinterpret_cast<const char*>(skeleton.data()),
                                                   reinterpret_cast<const char*>(skeleton.data()) + skeleton.size()),
                                 path);
        share = true;
    }
    return true;
}

void SceneRun::saveCheckpoint() {
    const Comm& comm = Comm::world();
    if (comm.distributed() && scene_.output.rankFiles == "per_rank") {
        saveCheckpointParts();
        return;
    }
    // What one process would write: on several ranks the particles are gathered to rank 0 first.
    const SimState gathered = comm.distributed() ? sim_->gatherState() : SimState{};
    const SimState& s = comm.distributed() ? gathered : sim_->state();
    lastCheckpoint_ = checkpointPath(dir_, scene_.name, s.frame, s.frameSubsteps > 0);
    onRoot(comm, [&] { writeCheckpointFiles(s); });
}

void SceneRun::saveCheckpointParts() {
    // Every rank writes its part; the set's id tells the parts written together from those of an earlier set.
    const Comm& comm = Comm::world();
    Bytes id;
    if (comm.rank() == 0) {
        std::random_device entropy;
        char buf[24];
        std::snprintf(buf, sizeof buf, "%08x%08x", entropy(), entropy());
        putArray(id, buf, std::strlen(buf));
    }
    id = comm.broadcast(id, 0);
    const SimState& s = sim_->state();
    CheckpointInfo info = checkpointInfo(s, comm.rank() == 0);
    info.part = comm.rank();
    info.parts = comm.size();
    info.set.assign(reinterpret_cast<const char*>(id.data()), id.size());
    const bool inside = s.frameSubsteps > 0;
    lastCheckpoint_ = checkpointPartPath(dir_, scene_.name, s.frame, -1, inside);
    agreeOnFailure(comm, true,
                   [&] { writeCheckpoint(checkpointPartPath(dir_, scene_.name, s.frame, comm.rank(), inside), info, s); });
    // The set is whole: what else this checkpoint had (a whole file, parts of a larger set) and older ones go.
    onRoot(comm, [&] { rotateCheckpoints(s, comm.size()); });
}

void SceneRun::rotateCheckpoints(const SimState& s, int parts) {
    // The one just written (whole when parts is 0) replaces what else was written at its moment; a checkpoint of a
    // stopped run goes once a newer one exists, and of those after whole frames the newest `checkpoints_kept` stay.
    const bool inside = s.frameSubsteps > 0;
    const auto order = [](int frame, bool in) { return 2LL * frame + (in ? 1 : 0); };
    const long long written = order(s.frame, inside);
    std::error_code ec;
    std::size_t afterFrames = 0;
    for (const CheckpointFiles& c : listCheckpoints(dir_, scene_.name)) {
        const long long at = order(c.frame, c.inside);
        if (at == written) {
            if (parts > 0 && !c.whole.empty()) fs::remove(c.whole, ec);
            for (const auto& [k, p] : c.parts)
                if (parts == 0 || k >= parts) fs::remove(p, ec);
        } else if (c.inside && at < written) {
            for (const std::string& p : c.all()) fs::remove(p, ec);
            continue;
        }
        if (!c.inside && afterFrames++ >= std::size_t(scene_.output.checkpointsKept))
            for (const std::string& p : c.all()) fs::remove(p, ec);
    }
}

CheckpointInfo SceneRun::checkpointInfo(const SimState& s, bool withStats) const {
    CheckpointInfo info;
    info.format = kCheckpointFormat;
    info.program = std::string("sparse-mpm ") + MPM_VERSION;
    info.sceneName = scene_.name;
    info.frame = s.frame;
    info.time = s.time;
    info.midFrame = s.frameSubsteps > 0;
    info.sceneHash = hash_;
    info.sceneJson = identity_;
    if (withStats) info.statsCsv = writer_->statsCsv();
    return info;
}

bool SceneRun::supersededCheckpoint(int frame) const {
    // Only a run of part of a scene (--frames) can find newer checkpoints than its own: those of the frames after
    // its range. A checkpoint that the kept count would rotate away at once is not written.
    if (!options_.framesGiven) return false;
    int newer = 0;
    onRoot(Comm::world(), [&] {
        for (const CheckpointFiles& files : listCheckpoints(dir_, scene_.name)) newer += files.frame > frame;
    });
    return Comm::world().max(float(newer)) >= float(scene_.output.checkpointsKept);
}

void SceneRun::writeCheckpointFiles(const SimState& s) {
    writeCheckpoint(checkpointPath(dir_, scene_.name, s.frame, s.frameSubsteps > 0), checkpointInfo(s, true), s);
    rotateCheckpoints(s, 0);
}

void SceneRun::reportRanks() {
    const Comm& comm = Comm::world();
    if (!comm.distributed()) return;
    const double mine = double(sim_->particleCount());
    const double fewest = comm.min(mine), most = comm.max(mine);
    const double sent = comm.max(double(comm.bytesSent()));
    const PhaseSeconds& t = sim_->phaseSeconds();
    const double share = comm.max(t.total() > 0.0 ? t.communication / t.total() : 0.0);
    const double held = comm.max(double(heldSamples_));
    char line[320];
    std::snprintf(
        line, sizeof line,
        "%d ranks: %.0f to %.0f particles each at the end; leaves re-cut %d times; at most %.3g MB sent by a rank, "
        "at most %.1f%% of a rank's substep time spent communicating; at most %.0f of the sets' %lld samples held by a rank",
        comm.size(), fewest, most, sim_->rebalanceCount(), sent / 1e6, 100.0 * share, held, setSamples_);
    events_.note(line);
}

void SceneRun::run(const std::atomic<int>* stop) {
    sim_->setStopRequest(stop);
    const int every = scene_.output.checkpointEvery;
    for (int f = start_ + 1; f <= last_; ++f) {
        FrameStats st;
        try {
            guarded("simulating frame " + std::to_string(f), [&] { st = sim_->advanceFrame(); });
        } catch (const Interrupted&) {
            saveCheckpoint();
            throw;
        }
        guarded("writing frame " + std::to_string(f), [&] { writeFrame(f, st, f >= options_.firstFrame); });
        // On a stop request a checkpoint is written even when the scene asks for none.
        const bool saved = every > 0 && (f % every == 0 || f == last_) && !supersededCheckpoint(f);
        if (saved) guarded("writing the checkpoint of frame " + std::to_string(f), [&] { saveCheckpoint(); });
        const FrameWriter* wrote = partWriter_ ? partWriter_.get() : writer_.get();
        events_.frameDone(f, last_, st, f >= options_.firstFrame && wrote ? wrote->lastWriteSeconds() : 0.0);
        // A stop asked for while the frame was written: the state is at a frame boundary (every rank agrees).
        const bool stopAsked = stop && stop->load();
        if (Comm::world().max(stopAsked ? 1.0f : 0.0f) > 0.0f && f < last_) {
            if (!saved) saveCheckpoint();
            throw Interrupted();
        }
    }
    // A stopped run's checkpoint inside a frame this run has since written is spent (without checkpoint_every no
    // newer checkpoint replaced it): a later --resume would redo frames that are done.
    onRoot(Comm::world(), [&] {
        std::error_code ec;
        for (const CheckpointFiles& c : listCheckpoints(dir_, scene_.name))
            if (c.inside && c.frame < last_)
                for (const std::string& p : c.all()) fs::remove(p, ec);
    });
    reportRanks();
}

}  // namespace mpm
