// Google Benchmark for the kernels of one substep, on the benchmark block (BenchScene.h) with
// 8 particles per cell: topology update, binning, P2G, grid update and G2P per material, and the
// per-particle material work (stress, return mapping, SVD) apart. Counters report particles per second.
//   mpm_bench_kernels [--benchmark_filter=...] [--benchmark_out=kernels.json --benchmark_out_format=json]
// The particle count is 2^18 (64^3) unless MPM_BENCH_PARTICLES says otherwise.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <map>
#include <random>
#include <tuple>

#include "BenchScene.h"
#include "core/GridUpdate.h"

using namespace mpm;
using namespace mpm::bench;

namespace {

/// Spray: particles scattered so that most are alone in their leaf (BenchScene::spray).
constexpr long kSprayParticles = 20000;

long kernelParticles() {
    const char* env = std::getenv("MPM_BENCH_PARTICLES");
    return env ? std::atol(env) : 262144;
}

/// Species sorted by leaf, a grid built for them, and a grid velocity field from one P2G and grid update.
struct KernelScene {
    std::vector<AnySpecies> species;
    SparseGrid grid;
    std::vector<std::vector<uint32_t>> destination;
    std::vector<BinRequest> requests;
    std::vector<std::unique_ptr<Collider>> colliders;
    TransferSettings transfer;
    float dt = float(kTargetDt);

    explicit KernelScene(const std::string& material, Interpolation kernel = Interpolation::Quadratic, bool spray = false) {
        BenchScene b;
        b.material = material;
        b.kernel = kernel;
        b.particles = spray ? kSprayParticles : kernelParticles();
        b.spray = spray;
        auto sim = makeBenchSimulation(b);
        sim->substep(kTargetDt);  // sorts the particles by leaf: later binning finds them in order
        species = sim->species();
        transfer.interpolation = kernel;
        withKernel(kernel, [&]<class K>() { grid.configure(kDx, K::kBaseShift, K::kWidth); });
        destination.resize(species.size());
        for (std::size_t s = 0; s < species.size(); ++s)
            std::visit(
                [&](auto& sp) {
                    requests.push_back(BinRequest{&sp.p.x, &sp.p.id, &destination[s], &sp.leafStart});
                },
                species[s]);
        grid.rebuild(requests);
        colliders.push_back(planeCollider(Vec3d::Zero(), Vec3d::UnitY(), Boundary::Slip, 0.0f));
        particlesToGrid(grid, species, transfer, dt);
        updateGridVelocities(grid, colliders, Vec3f(0, -9.81f, 0), dt, 0.0, SurfaceContact{});
    }
    long particles() const {
        long n = 0;
        for (const AnySpecies& s : species) n += long(particlesOf(s).size());
        return n;
    }
};

KernelScene& scene(const std::string& material, Interpolation kernel = Interpolation::Quadratic, bool spray = false) {
    static std::map<std::tuple<std::string, int, bool>, std::unique_ptr<KernelScene>> cache;
    auto& s = cache[{material, int(kernel), spray}];
    if (!s) s = std::make_unique<KernelScene>(material, kernel, spray);
    return *s;
}

void perParticle(benchmark::State& st, long n) {
    st.counters["particles/s"] = benchmark::Counter(double(n), benchmark::Counter::kIsIterationInvariantRate);
    st.SetItemsProcessed(st.iterations() * n);
}

void BM_TopologyUpdate(benchmark::State& st) {
    KernelScene& s = scene("water");
    for (auto _ : st) s.grid.updateTopology(s.requests);
    perParticle(st, s.particles());
}
BENCHMARK(BM_TopologyUpdate)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_Binning(benchmark::State& st) {
    KernelScene& s = scene("water");
    for (auto _ : st) s.grid.sortParticles(s.requests);
    perParticle(st, s.particles());
}
BENCHMARK(BM_Binning)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_GridUpdate(benchmark::State& st) {
    KernelScene& s = scene("water");
    for (auto _ : st)
        benchmark::DoNotOptimize(updateGridVelocities(s.grid, s.colliders, Vec3f(0, -9.81f, 0), s.dt, 0.0, SurfaceContact{}));
    perParticle(st, s.particles());
}
BENCHMARK(BM_GridUpdate)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_P2G(benchmark::State& st, const char* material, Interpolation kernel) {
    KernelScene& s = scene(material, kernel);
    for (auto _ : st) particlesToGrid(s.grid, s.species, s.transfer, s.dt);
    perParticle(st, s.particles());
}
void BM_G2P(benchmark::State& st, const char* material, Interpolation kernel) {
    KernelScene& s = scene(material, kernel);
    // A small step: the particles stay in their leaves however many iterations run.
    for (auto _ : st) benchmark::DoNotOptimize(gridToParticles(s.grid, s.species, s.transfer, 1e-3f * s.dt));
    perParticle(st, s.particles());
}
/// A whole substep's transfers on spray, where the per-leaf costs (zeroing, the local blocks, the grid
/// update over the 8 leaves a lone particle touches) dominate the per-particle ones.
void BM_SprayTransfers(benchmark::State& st) {
    KernelScene& s = scene("water", Interpolation::Quadratic, true);
    for (auto _ : st) {
        particlesToGrid(s.grid, s.species, s.transfer, s.dt);
        updateGridVelocities(s.grid, s.colliders, Vec3f(0, -9.81f, 0), s.dt, 0.0, SurfaceContact{});
        benchmark::DoNotOptimize(gridToParticles(s.grid, s.species, s.transfer, 1e-3f * s.dt));
    }
    perParticle(st, s.particles());
}
BENCHMARK(BM_SprayTransfers)->Unit(benchmark::kMillisecond)->UseRealTime();

#define MPM_TRANSFER_BENCH(material, kernel)                                         \
    BENCHMARK_CAPTURE(BM_P2G, material##_##kernel, #material, Interpolation::kernel) \
        ->Unit(benchmark::kMillisecond)                                              \
        ->UseRealTime();                                                             \
    BENCHMARK_CAPTURE(BM_G2P, material##_##kernel, #material, Interpolation::kernel) \
        ->Unit(benchmark::kMillisecond)                                              \
        ->UseRealTime();
MPM_TRANSFER_BENCH(water, Quadratic)
MPM_TRANSFER_BENCH(jelly, Quadratic)
MPM_TRANSFER_BENCH(snow, Quadratic)
MPM_TRANSFER_BENCH(sand, Quadratic)
MPM_TRANSFER_BENCH(water, Cubic)
MPM_TRANSFER_BENCH(jelly, Cubic)

/// Deformation gradients near rest, rotated: what the stress and SVD see in a running scene.
std::vector<Mat3f> sampleF(std::size_t n) {
    std::mt19937 rng(7);
    std::normal_distribution<float> g(0.0f, 0.05f);
    std::vector<Mat3f> F(n);
    for (Mat3f& f : F) {
        const Eigen::Quaternionf q(1.0f, g(rng) * 10, g(rng) * 10, g(rng) * 10);
        f = q.normalized().toRotationMatrix();
        for (int i = 0; i < 9; ++i) f(i / 3, i % 3) += g(rng);
    }
    return F;
}

template <Svd3<float> (*Fn)(const Mat3f&)>
void BM_Svd(benchmark::State& st) {
    const std::vector<Mat3f> F = sampleF(4096);
    for (auto _ : st)
        for (const Mat3f& f : F) benchmark::DoNotOptimize(Fn(f));
    perParticle(st, long(F.size()));
}
BENCHMARK_TEMPLATE(BM_Svd, svd3<float>)->Name("BM_Svd/mcadams_style");
BENCHMARK_TEMPLATE(BM_Svd, jacobiSvd3<float>)->Name("BM_Svd/eigen_jacobi");

void BM_SvdBatch(benchmark::State& st) {  // eight per call, in SIMD lanes
    const std::vector<Mat3f> F = sampleF(4096);
    Svd3<float> out[simd::kLanes];
    for (auto _ : st)
        for (std::size_t i = 0; i < F.size(); i += simd::kLanes) {
            svd3Batch(&F[i], simd::kLanes, out);
            benchmark::DoNotOptimize(out);
        }
    perParticle(st, long(F.size()));
}
BENCHMARK(BM_SvdBatch)->Name("BM_Svd/batch_of_8");

/// The material work alone: Kirchhoff stress (P2G) and deformation update with return mapping (G2P).
template <class M>
void BM_Material(benchmark::State& st) {
    const std::vector<Mat3f> F = sampleF(4096);
    Species<M> sp;
    if constexpr (requires { sp.state.appendRest(F.size(), sp.params); })
        sp.state.appendRest(F.size(), sp.params);
    else
        sp.state.appendRest(F.size());
    Mat3f sum = Mat3f::Zero();
    std::mt19937 rng(3);
    std::normal_distribution<float> g(0.0f, 1.0f);
    Mat3f gradV;
    for (int i = 0; i < 9; ++i) gradV(i / 3, i % 3) = g(rng);
    const Mat3f gradVs[simd::kLanes] = {gradV, gradV, gradV, gradV, gradV, gradV, gradV, gradV};
    Mat3f tau[simd::kLanes];
    for (auto _ : st) {
        // As the transfers call them: a batch of simd::kLanes particles at a time.
        for (std::size_t i = 0; i < F.size(); i += simd::kLanes) {
            for (std::size_t k = i; k < i + simd::kLanes; ++k) {
                if constexpr (requires { sp.state.F; }) sp.state.F[k] = F[k].cast<double>();
                if constexpr (requires { sp.state.Fe; }) sp.state.Fe[k] = F[k].cast<double>();
            }
            kirchhoffOfRange<M>(sp.params, sp.state, i, simd::kLanes, tau);
            for (const Mat3f& t : tau) sum += t;
            updateDeformationOfRange<M>(sp.params, sp.state, i, simd::kLanes, gradVs, float(kTargetDt));
        }
        benchmark::DoNotOptimize(sum);
    }
    perParticle(st, long(F.size()));
}
BENCHMARK_TEMPLATE(BM_Material, Water);
BENCHMARK_TEMPLATE(BM_Material, FixedCorotated);
BENCHMARK_TEMPLATE(BM_Material, NeoHookean);
BENCHMARK_TEMPLATE(BM_Material, Snow);
BENCHMARK_TEMPLATE(BM_Material, Sand);

}  // namespace

BENCHMARK_MAIN();
