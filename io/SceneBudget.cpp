#include "io/SceneBudget.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <numeric>
#include <optional>
#include <sstream>

#include "io/MaterialFields.h"
#include "io/Sampling.h"
#include "io/SceneBuilder.h"

namespace mpm {

namespace {

/// Bytes per particle besides its arrays: the sort destination and the halo workspace of P2G.
constexpr double kEngineBytesPerParticle = 4.0 + 3.0;
/// Grid nodes per particle at one particle per cell, counting partly filled leaves and halo leaves (measured
/// on the benchmark block: about 143 bytes per water particle in all at 8 per cell).
constexpr double kNodesPerCellOfParticles = 4.0;
constexpr double kBytesPerNode = 4.0 * sizeof(float);
/// Writing a frame gathers the particles into flat arrays and builds the VDB points grid.
constexpr double kOutputBytesPerParticle = 80.0;

std::string gib(double bytes) {
    std::ostringstream s;
    s.precision(3);
    s << bytes / double(1u << 30) << " GiB";
    return s.str();
}

/// The fields a budget holds, to follow a particle count: " and X of collider distance fields", ", X of collider
/// distance fields and Y of a set's distance field", or nothing.
std::string fieldsInWords(const SceneBudget& b) {
    const std::string colliders = gib(b.colliderBytes) + " of collider distance fields",
                      sets = gib(b.setFieldBytes) + " of a set's distance field";
    if (b.colliderBytes > 0.0 && b.setFieldBytes > 0.0) return ", " + colliders + " and " + sets;
    if (b.colliderBytes > 0.0) return " and " + colliders;
    if (b.setFieldBytes > 0.0) return " and " + sets;
    return "";
}

/// Bytes of one particle of material M: every per-particle array, and the permutation buffer's share (it
/// is as wide as the widest array).
template <class M>
double particleBytes() {
    Species<M> s;
    double sum = 0.0, widest = 0.0;
    s.forEachArray([&](const auto& a) {
        const double b = double(sizeof(typename std::decay_t<decltype(a)>::value_type));
        sum += b;
        widest = std::max(widest, b);
    });
    return sum + widest;
}

/// Wave speed of a material at rest with these parameters.
template <class M>
float restWaveSpeed(const typename M::Params& p) {
    Species<M> s;
    s.params = p;
    if constexpr (requires { s.state.appendRest(1, s.params); })
        s.state.appendRest(1, s.params);
    else
        s.state.appendRest(1);
    return M::waveSpeed(p, M::stiffnessKey(s.state, 0));
}

long long emissionsWithin(const ParticleSetDesc& d, int frames) {
    long long n = 0;
    const long long period = d.pauseFrames + 1;
    const long long last = std::min<long long>((long long)d.startFrame + d.durationFrames - 1, frames);
    if (last >= d.startFrame) n = (last - d.startFrame) / period + 1;
    return n;
}

/// Frames that a set's particles of one emission spend in the scene, summed over its emissions (a stream's whole
/// flow: its particles enter evenly over its duration).
double framesPresent(const ParticleSetDesc& d, int frames) {
    if (d.continuous) {
        const double flowing = std::clamp(double(frames - d.startFrame), 0.0, double(d.durationFrames));
        return flowing > 0.0 ? (double(frames - d.startFrame) - 0.5 * flowing) * flowing / double(d.durationFrames) : 0.0;
    }
    double sum = 0.0;
    for (long long k = 0, e = d.startFrame; k < emissionsWithin(d, frames) && e < frames; ++k, e += d.pauseFrames + 1)
        sum += double(frames - e);
    return sum;
}

std::string duration(double seconds) {
    std::ostringstream s;
    s.precision(2);
    if (seconds < 1.0)
        s << "under a second";
    else if (seconds < 120.0)
        s << std::fixed << seconds << " s";
    else if (seconds < 2.0 * 3600.0)
        s << std::fixed << seconds / 60.0 << " min";
    else if (seconds < 2.0 * 86400.0)
        s << std::fixed << seconds / 3600.0 << " h";
    else
        s << std::fixed << seconds / 86400.0 << " days";
    return s.str();
}

}  // namespace

double cgroupMemoryLimit(const std::string& procCgroup, const std::string& root, std::string& where) {
    double least = std::numeric_limits<double>::infinity();
    // A limit file's number ("max", or v1's page-rounded 2^63, when there is none).
    const auto limitIn = [&](const std::string& file) {
        std::ifstream in(file);
        std::string word;
        if (!(in >> word) || word == "max") return;
        try {
            const double bytes = std::stod(word);
            if (bytes > 0.0 && bytes < least) least = bytes, where = file;
        } catch (const std::exception&) {
            // Not a number: no limit we can read.
        }
    };
    std::istringstream lines(procCgroup);
    for (std::string line; std::getline(lines, line);) {
        // "hierarchy-ID:controllers:path": v2 has ID 0 and no controllers; v1's memory controller names "memory".
        const std::size_t a = line.find(':'), b = line.find(':', a + 1);
        if (a == std::string::npos || b == std::string::npos) continue;
        const std::string controllers = line.substr(a + 1, b - a - 1);
        std::string dir = line.substr(b + 1);
        const bool v2 = controllers.empty(), v1 = !v2 && ("," + controllers + ",").find(",memory,") != std::string::npos;
        if (!v1 && !v2) continue;
        const std::string base = root + (v1 ? "/memory" : "");
        const std::string file = v1 ? "/memory.limit_in_bytes" : "/memory.max";
        // The group and each one above it: a limit anywhere up the tree caps this process.
        for (;;) {
            limitIn(base + (dir == "/" ? "" : dir) + file);
            if (dir.empty() || dir == "/") break;
            const std::size_t up = dir.rfind('/');
            dir = up == 0 || up == std::string::npos ? "/" : dir.substr(0, up);
        }
    }
    return least;
}

MemoryLimit memoryLimit() {
    MemoryLimit m{double(::sysconf(_SC_PHYS_PAGES)) * double(::sysconf(_SC_PAGE_SIZE)), "this machine has"};
    std::ifstream in("/proc/self/cgroup");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::string where;
    const double group = cgroupMemoryLimit(text, "/sys/fs/cgroup", where);
    if (group < m.bytes) m = MemoryLimit{group, "its control group allows (" + where + ")"};
    return m;
}

double machineMemoryBytes() { return memoryLimit().bytes; }

double addressSpaceLeft() {
    rlimit limit{};
    if (::getrlimit(RLIMIT_AS, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return std::numeric_limits<double>::infinity();
    // What is mapped now: the first field of /proc/self/statm, in pages.
    std::ifstream statm("/proc/self/statm");
    double pages = 0.0;
    statm >> pages;
    return std::max(0.0, double(limit.rlim_cur) - pages * double(::sysconf(_SC_PAGE_SIZE)));
}

SceneBudget estimateBudget(const SceneDesc& scene, bool countExactly, int ranks, SetCache* given) {
    std::optional<SetCache> own;
    SetCache& cache = given ? *given : own.emplace(scene);
    SceneBudget b;
    const SimulationSettings& st = scene.settings;
    const double dx = st.dx, cell = dx * dx * dx;
    float c = 0.0f, vmax = 0.0f;
    std::string stiffest;
    for (std::size_t i = 0; i < scene.sets.size(); ++i) {
        const SetEntry set(scene, i);
        const ParticleSetDesc& d = set.desc();
        SetBudget s;
        s.name = d.name;
        Vec3d lo, hi;
        cache.extent(i, s.volume, lo, hi);
        const double largestCoordinate = std::max(lo.cwiseAbs().maxCoeff(), hi.cwiseAbs().maxCoeff());
        const double expected = d.count > 0 ? double(d.count) : s.volume / cell * d.particlesPerCell;
        const SetSamples* samples = nullptr;  // when counted exactly
        std::optional<FieldParams> fields;    // its material fields at those samples
        if (!d.continuous && countExactly && expected <= kSampleUpTo) {
            samples = &cache.samples(i);
            if (!d.materialFields.empty()) fields = fieldParams(set, *samples, Comm::single());
        }
        if (samples)
            s.particles = (long long)samples->positions.size();
        else if (d.count > 0)
            s.particles = d.count;
        else
            s.particles = (long long)std::min(expected, 9e18), s.estimated = true;
        s.emissions = d.continuous ? 1 : emissionsWithin(d, scene.frames);  // a stream's volume is its whole flow
        // A set that starts after the last frame never sets the step (sceneWarnings says it never appears).
        const bool appears = d.continuous ? d.startFrame < scene.frames : s.emissions > 0;
        double perParticle = 0.0, density = 0.0;
        visitMaterialParams(d.params, [&]<class M>(const typename M::Params& p) {
            // Parameters per particle are one more array; the CFL bound takes the stiffest particle's where the set
            // was sampled, else the set's own.
            perParticle = particleBytes<M>() + (d.materialFields.empty() ? 0.0 : double(sizeof(typename M::Params)));
            density = p.density;
            typename M::Params scaled = p;
            M::scaleStiffness(scaled, d.lambdaScale, d.muScale);
            if (fields) scaled = std::get<typename M::Params>(fields->stiffest);
            const float w = restWaveSpeed<M>(scaled);
            if (appears && !(w <= c)) c = w, stiffest = d.name;  // a NaN wave speed wins, and is reported below
            if (const char* why = stiffening<M>(scaled); why && b.stiffening.empty())
                b.stiffening = "set " + d.name + "'s " + M::kSceneName + " " + why;
        });
        s.mass = s.volume * density * d.massScale;
        if (samples && !samples->positions.empty()) {
            // Its particles' own masses where they have them (a point cloud's, a density field's).
            const float volume = float(samples->volume / double(samples->positions.size()));
            const std::vector<float> masses =
                particleMasses(d, float(density), volume, *samples, fields ? fields->densities : std::vector<float>{});
            if (!masses.empty()) s.mass = std::accumulate(masses.begin(), masses.end(), 0.0);
        }
        if (appears) vmax = std::max(vmax, d.velocity.norm());
        const double total = double(s.particles) * double(s.emissions);
        b.peakParticles += total;
        b.particleSubsteps += double(s.particles) * framesPresent(d, scene.frames);
        const double gridPerParticle = kNodesPerCellOfParticles * kBytesPerNode / d.particlesPerCell;
        const double simulated = perParticle + kEngineBytesPerParticle + gridPerParticle;
        // On ranks, rank 0 simulates its share and gathers every particle to write a frame or a checkpoint,
        // unless frames and checkpoints go to per-rank part files.
        const bool gathers = scene.output.rankFiles == "gathered";
        const double perRank = ranks > 1 ? simulated / ranks + (gathers ? perParticle : 0.0) : simulated;
        const double output =
            ranks > 1 && scene.output.rankFiles == "per_rank" ? kOutputBytesPerParticle / ranks : kOutputBytesPerParticle;
        // The emitter keeps its samples until it last emits: on ranks, each its part of a set given by its
        // density; every sample of a set given by its count, or of a point cloud, while it is sampled.
        const bool inParts = ranks > 1 && d.count <= 0 && !std::holds_alternative<PointsShape>(d.shape);
        b.memoryBytes += total * (perRank + output) + double(s.particles) * sizeof(Vec3d) / (inParts ? ranks : 1);
        if (largestCoordinate / dx >= kMaxGridCoordinate) {
            std::ostringstream p;
            p << set.path("shape") << ": lies " << largestCoordinate
              << " m from the origin, beyond the grid's coordinate range of "
              << "+-2^30 cells (" << kMaxGridCoordinate * dx << " m at dx = " << dx
              << " m); move it nearer the origin or use a larger dx";
            b.problems.push_back(p.str());
        }
        b.sets.push_back(s);
    }
    // The first step: the target, or the CFL bound at rest (the same rule as the engine's).
    const double target = st.targetDt();
    const double speed = double(c) + double(vmax), g = st.gravity.norm(), reach = st.cfl * dx;
    const double cfl = 2.0 * reach / (speed + std::sqrt(speed * speed + 4.0 * g * reach));
    b.dt = st.adaptive ? std::min(target, cfl) : target;
    // The thesis's displacement rule binds at any setting of adaptive, once anything moves.
    const double displacement = st.maxDisplacement > 0.0 && vmax > 0.0f ? st.maxDisplacement * dx / double(vmax)
                                                                        : std::numeric_limits<double>::infinity();
    std::ostringstream cause;
    if (displacement < b.dt) {
        b.dt = displacement;
        cause << "the displacement rule, simulation.max_displacement = " << st.maxDisplacement
              << " cells a substep at the initial speed " << vmax << " m/s";
    } else if (!st.adaptive || target <= cfl)
        cause << "the target step 1 / (fps * substeps)";
    else if (c >= vmax)
        cause << "the CFL bound from the wave speed " << c << " m/s of set " << stiffest;
    else
        cause << "the CFL bound from the initial speed " << vmax << " m/s";
    b.stepCause = cause.str();
    b.substepsPerFrame = std::ceil(1.0 / (st.fps * b.dt));
    b.particleSubsteps *= b.substepsPerFrame;
    if (!(b.substepsPerFrame <= double(st.maxSubstepsPerFrame))) {
        std::ostringstream p;
        p << (st.substepsPerFrame > st.maxSubstepsPerFrame ? "/simulation/substeps" : "/simulation")
          << ": frames would need about " << b.substepsPerFrame << " substeps each (dt = " << b.dt << " s, set by " << b.stepCause
          << "); the limit is simulation.max_substeps_per_frame = " << st.maxSubstepsPerFrame
          << "; lower the stiffness or the speed, raise dx, raise simulation.fps (shorter frames need fewer substeps each), or "
             "raise the limit";
        b.problems.push_back(p.str());
    }
    for (std::size_t i = 0; i < scene.colliders.size(); ++i) {
        const double far = std::visit(
            []<class S>(const S& s) {
                if constexpr (kFromFile<S>)
                    return 0.0;  // known once its file is read
                else
                    return s.middle().cwiseAbs().maxCoeff();
            },
            scene.colliders[i].shape);
        if (far / dx >= kMaxGridCoordinate) {
            std::ostringstream p;
            p << ColliderEntry(scene, i).path() << ": lies " << far
              << " m from the origin, beyond the grid's coordinate range of +-2^30 cells (" << kMaxGridCoordinate * dx
              << " m at dx = " << dx << " m)";
            b.problems.push_back(p.str());
        }
    }
    // Every rank holds every collider's field whole.
    for (std::size_t i = 0; i < scene.colliders.size(); ++i) b.colliderBytes += colliderFieldBytes(ColliderEntry(scene, i));
    // A set's field lives while the set is sampled (and tested for overlaps), one set at a time, beside the
    // particles sampled so far: the largest counts, as if it lived on with the colliders', an upper bound.
    for (std::size_t i = 0; i < scene.sets.size(); ++i)
        b.setFieldBytes = std::max(b.setFieldBytes, setFieldBytes(SetEntry(scene, i)));
    b.memoryBytes += b.colliderBytes + b.setFieldBytes;
    const MemoryLimit limit = memoryLimit();
    b.machineBytes = limit.bytes;
    b.machineHolder = limit.holder;
    if (b.memoryBytes > b.machineBytes)
        b.problems.push_back(
            "/sets: " +
            std::string(ranks > 1 ? "rank 0 of " + std::to_string(ranks) + " (its share" +
                                        std::string(scene.output.rankFiles == "gathered"
                                                        ? ", and every particle gathered to write a frame or checkpoint)"
                                                        : ")")
                                  : "the run") +
            " needs about " + gib(b.memoryBytes) + " for about " + std::to_string((long long)b.peakParticles) + " particles" +
            fieldsInWords(b) + ", and " + b.machineHolder + " " + gib(b.machineBytes) +
            "; use fewer particles (particles_per_cell, count, duration) or a larger dx" +
            (b.colliderBytes + b.setFieldBytes > 0.0 ? ", or a coarser voxel_size for the meshes" : ""));
    return b;
}

std::string describeBudget(const SceneBudget& b) {
    std::ostringstream s;
    for (const SetBudget& set : b.sets)
        s << "set " << set.name << ": " << (set.estimated ? "about " : "") << set.particles << " particles, " << set.mass
          << " kg, " << set.volume << " m^3 per emission; " << set.emissions << " emission" << (set.emissions == 1 ? "" : "s")
          << "\n";
    s << "memory: about " << gib(b.memoryBytes) << " at the peak (" << (long long)b.peakParticles << " particles";
    s << fieldsInWords(b);
    s << "); " << b.machineHolder << " " << gib(b.machineBytes) << "\n";
    s << "substeps per frame: about " << b.substepsPerFrame << " at the start (dt = " << b.dt << " s, set by " << b.stepCause
      << ")\n";
    // Measured: a snowball thrown at a wall (scenes/snowball_wall.json) ran 31,171 substeps where 4,250 were estimated.
    if (!b.stiffening.empty())
        s << "  and more later: " << b.stiffening
          << ", which shortens the step; a snowball thrown at a wall ran 7.3 times the substeps estimated here\n";
    if (b.runSeconds > 0.0) {
        const std::string d = duration(b.runSeconds);
        s << "run time: "
          << (d.rfind("under", 0) == 0 ? ""
              : b.stiffening.empty()   ? "about "
                                       : "at least ")
          << d << " here (" << b.runBasis << ")\n";
    }
    return s.str();
}

void checkBudget(const SceneDesc& scene, const SceneBudget& budget) {
    if (budget.problems.empty()) return;
    std::string msg = scene.file + ": " + budget.problems.front();
    for (std::size_t i = 1; i < budget.problems.size(); ++i) msg += "\n" + scene.file + ": " + budget.problems[i];
    throw SceneError(msg);
}

}  // namespace mpm
