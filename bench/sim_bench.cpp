// Simulator speed (issue 2 part 7): ns per integration step on the scalar path, amortised ns per
// simulation-step on the batched SIMD path on one and two cores, and the wall time of the paper's
// dataset size (2000 simulations of 0.5 s at 1 us = 1e9 simulation-steps).
#include "emadiag/sim/simulator.hpp"

#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdio>
#include <random>

namespace {

using emadiag::sim::SimConfig;

constexpr double kStepsPerRun = 0.5 / 1e-6;

std::vector<SimConfig> configs(std::size_t n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    auto u = [&] { return static_cast<double>(rng() >> 11) * (1.0 / 9007199254740992.0); };
    std::vector<SimConfig> v(n);
    for (auto& c : v) {
        c.params.fdj_nm = 0.064 + 0.032 * u();
        c.params.fsj_nm = 0.096 + 0.048 * u();
        c.params.eta_a = 0.659031 + (0.988546 - 0.659031) * u();
        c.params.eta_o = emadiag::sim::eta_o_from_eta_a(c.params.eta_a, c.params.tau);
    }
    return v;
}

void BM_ScalarStep(benchmark::State& state) {
    SimConfig c;
    for (auto _ : state) {
        auto r = emadiag::sim::simulate(c);
        benchmark::DoNotOptimize(r.samples.data());
    }
    // Seconds per integration step; printed with an SI prefix ("17.4n" = 17.4 ns).
    state.counters["s_per_step"] = benchmark::Counter(kStepsPerRun * static_cast<double>(state.iterations()),
                                                      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_ScalarStep)->Unit(benchmark::kMillisecond);  // CPU time: robust on a busy machine

void BM_BatchStep(benchmark::State& state) {
    const auto threads = static_cast<unsigned>(state.range(0));
    const auto cs = configs(static_cast<std::size_t>(emadiag::sim::kBatchLanes * emadiag::sim::kBatchGroups * 2 * threads), 7);
    for (auto _ : state) {
        auto r = emadiag::sim::simulate_batch(cs, threads);
        benchmark::DoNotOptimize(r.data());
    }
    const double sim_steps = kStepsPerRun * static_cast<double>(cs.size()) * static_cast<double>(state.iterations());
    state.counters["s_per_sim_step"] = benchmark::Counter(sim_steps, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_BatchStep)->Arg(1)->Unit(benchmark::kMillisecond);  // one core: CPU time
BENCHMARK(BM_BatchStep)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();  // two cores: wall time

}  // namespace

int main(int argc, char** argv) {
    benchmark::Initialize(&argc, argv);
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    // The paper's dataset size, timed once on two threads.
    const auto cs = configs(2000, 42);
    const auto t0 = std::chrono::steady_clock::now();
    const auto r = emadiag::sim::simulate_batch(cs, 2);
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("paper dataset: %zu simulations x 0.5 s at 1 us (%.2e simulation-steps) in %.2f s wall on 2 threads "
                "(%.2f ns per simulation-step)\n",
                r.size(), kStepsPerRun * 2000.0, wall_s, wall_s / (kStepsPerRun * 2000.0) * 1e9);
    return 0;
}
