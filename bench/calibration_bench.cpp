// Accuracy and calibration of the physics estimator on a larger seeded set (issue 4 goals):
// normalised test MSE (section 8 space), FSJ relative errors, and the coverage of the 95 %
// intervals, for noise none and typical. Then the estimator's speed as Google benchmarks.
//   calibration_bench [count [seed]]   (defaults 200, 7); set count 0 to skip the figures.
#include "core/sim_run.hpp"
#include "research/physics_calibration.hpp"
#include "estimation/physics_estimator.hpp"

#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

namespace {

constexpr int kDefaultCount = 200;
constexpr std::uint64_t kDefaultSeed = 7;

void print_figures(int count, std::uint64_t seed) {
    using emadiag::sim::LoadCase;
    using emadiag::sim::NoiseProfile;
    using emadiag::sim::Sequence;
    const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
    std::printf("physics estimator calibration: %d runs per set, seed %llu, %u threads\n", count,
                static_cast<unsigned long long>(seed), threads);
    std::printf("goal: 95 %% intervals cover the truth in %.0f-%.0f %% of runs\n\n", 100 * emadiag::kCoverageMin,
                100 * emadiag::kCoverageMax);
    const struct { LoadCase c; Sequence s; } sets[] = {
        {LoadCase::B, Sequence::Dyn}, {LoadCase::A, Sequence::Dyn}, {LoadCase::AExt, Sequence::Dyn},
        {LoadCase::B, Sequence::Brk}, {LoadCase::A, Sequence::Brk}, {LoadCase::B, Sequence::Sweep}};
    for (const auto& set : sets) {
        for (NoiseProfile noise : {NoiseProfile::None, NoiseProfile::Typical}) {
            emadiag::CalibrationSpec spec;
            spec.load_case = set.c;
            spec.sequence = set.s;
            spec.noise = noise;
            spec.count = count;
            spec.seed = seed;
            spec.threads = threads;
            const auto r = emadiag::evaluate_physics(spec);
            std::printf("%s  (%.1f s)\n", emadiag::format_calibration(r).c_str(), r.seconds);
        }
    }
    std::printf("case A FDJ: floor set by the eta confound (normalised MSE) = %.4g\n\n",
                emadiag::case_a_fdj_floor_normalised(800.0));
}

void BM_EstimatePhysicsDynB(benchmark::State& state) {
    emadiag::sim::SimConfig c;
    const auto run = emadiag::check_run(emadiag::make_run(c, emadiag::sim::simulate(c)));
    for (auto _ : state) benchmark::DoNotOptimize(emadiag::estimate_physics(run));
}
BENCHMARK(BM_EstimatePhysicsDynB)->Unit(benchmark::kMillisecond);

void BM_EstimatePhysicsBrkTypical(benchmark::State& state) {
    emadiag::sim::SimConfig c;
    c.sequence = emadiag::sim::Sequence::Brk;
    c.noise = emadiag::sim::NoiseProfile::Typical;
    const auto run = emadiag::check_run(emadiag::make_run(c, emadiag::sim::simulate(c)));
    for (auto _ : state) benchmark::DoNotOptimize(emadiag::estimate_physics(run));
}
BENCHMARK(BM_EstimatePhysicsBrkTypical)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
    int count = kDefaultCount;
    std::uint64_t seed = kDefaultSeed;
    // Positional figures arguments first; the rest goes to Google Benchmark.
    int consumed = 1;
    if (argc > consumed && argv[consumed][0] != '-') count = std::atoi(argv[consumed++]);
    if (argc > consumed && argv[consumed][0] != '-') seed = std::strtoull(argv[consumed++], nullptr, 10);
    if (count > 0) print_figures(count, seed);
    int bargc = argc - consumed + 1;
    std::vector<char*> bargv{argv[0]};
    for (int i = consumed; i < argc; ++i) bargv.push_back(argv[i]);
    benchmark::Initialize(&bargc, bargv.data());
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
