// Simulator speed (issues 2 part 7 and 9): ns per integration step on the scalar path (simulate, its
// step compiled for each target), amortised ns
// per simulation-step on the batched SIMD path on one and two cores for each instruction set this
// CPU supports (scalar, SSE4, AVX2, AVX-512: the binary is built for baseline x86-64 and picks at run
// time), and the wall time of the paper's dataset size (2000 simulations of 0.5 s at 1 us = 1e9
// simulation-steps) on each. Every figure of one run comes from the same machine and load, so the
// ratios between targets are the thing to read on a busy machine.
//
//   sim_bench [--simd=LIST] [benchmark flags]
//     LIST: comma-separated targets (scalar, sse4, avx2, avx512) or "all" (default: all supported).
//     The paper dataset runs on the scalar path only when LIST names scalar (about 10 s per core).
//     EMADIAG_SIMD=avx2 sim_bench measures only that target (as any program with that variable would use).
#include "emadiag/sim/physics.hpp"
#include "emadiag/sim/simulator.hpp"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <random>
#include <sstream>
#include <string>

namespace {

namespace sim = emadiag::sim;
using emadiag::sim::SimConfig;

constexpr double kStepsPerRun = 0.5 / 1e-6;
constexpr const char* kSimdFlag = "--simd=";

std::vector<SimConfig> configs(std::size_t n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    auto u = [&] { return static_cast<double>(rng() >> 11) * (1.0 / 9007199254740992.0); };
    std::vector<SimConfig> v(n);
    for (auto& c : v) {
        // The section-8 ranges (physics.hpp). 0.032 is kPriorFdjMaxNm - kPriorFdjMinNm exactly; that
        // difference for FSJ rounds below 0.048, so the width of FSJ stays written.
        c.params.fdj_nm = sim::kPriorFdjMinNm + (sim::kPriorFdjMaxNm - sim::kPriorFdjMinNm) * u();
        c.params.fsj_nm = sim::kPriorFsjMinNm + 0.048 * u();
        c.params.eta_a = sim::kPriorEtaAMin + (sim::kPriorEtaAMax - sim::kPriorEtaAMin) * u();
        c.params.eta_o = emadiag::sim::eta_o_from_eta_a(c.params.eta_a, c.params.tau);
    }
    return v;
}

void BM_ScalarStep(benchmark::State& state, const std::string& target) {
    emadiag::sim::set_simd_target(target);
    SimConfig c;
    for (auto _ : state) {
        auto r = emadiag::sim::simulate(c);
        benchmark::DoNotOptimize(r.samples.data());
    }
    // simulate() runs the scalar step compiled for the chosen target (EMADIAG_SIMD=scalar: baseline).
    state.SetLabel("scalar step on " + emadiag::sim::simd_target().name);
    // Seconds per integration step; printed with an SI prefix ("17.4n" = 17.4 ns).
    state.counters["s_per_step"] = benchmark::Counter(kStepsPerRun * static_cast<double>(state.iterations()),
                                                      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_BatchStep(benchmark::State& state, const std::string& target) {
    emadiag::sim::set_simd_target(target);
    const emadiag::sim::SimdTarget t = emadiag::sim::simd_target();
    const auto threads = static_cast<unsigned>(state.range(0));
    // Two groups per thread of this target's width (one simulation per group on the scalar path: 8).
    const std::size_t width = t.name == "scalar" ? 4 : static_cast<std::size_t>(t.lanes * t.groups);
    const auto cs = configs(width * 2 * threads, 7);
    for (auto _ : state) {
        auto r = emadiag::sim::simulate_batch(cs, threads);
        benchmark::DoNotOptimize(r.data());
    }
    const double sim_steps = kStepsPerRun * static_cast<double>(cs.size()) * static_cast<double>(state.iterations());
    state.counters["s_per_sim_step"] = benchmark::Counter(sim_steps, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
    state.SetLabel(t.name + " " + std::to_string(t.lanes) + "x" + std::to_string(t.groups));
}

/// The console output, and the per-step figures kept for the summary.
class Reporter : public benchmark::ConsoleReporter {
public:
    void ReportRuns(const std::vector<Run>& runs) override {
        for (const Run& r : runs) {
            for (const char* counter : {"s_per_step", "s_per_sim_step"}) {
                const auto it = r.counters.find(counter);
                if (it != r.counters.end()) figures_[r.benchmark_name()] = it->second.value;
            }
        }
        ConsoleReporter::ReportRuns(runs);
    }
    [[nodiscard]] double figure(const std::string& name) const {
        const auto it = figures_.find(name);
        return it == figures_.end() ? 0.0 : it->second;
    }

private:
    std::map<std::string, double> figures_;
};

std::vector<std::string> split(const std::string& list) {
    std::vector<std::string> out;
    std::stringstream ss(list);
    for (std::string item; std::getline(ss, item, ',');) {
        if (!item.empty()) out.push_back(item);
    }
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    // --simd=LIST is ours; the rest goes to Google Benchmark.
    std::vector<std::string> targets;
    bool scalar_dataset = false;
    std::vector<char*> args;
    for (int i = 0; i < argc; ++i) {
        if (std::strncmp(argv[i], kSimdFlag, std::strlen(kSimdFlag)) == 0) {
            const std::string list = argv[i] + std::strlen(kSimdFlag);
            targets = list == "all" ? emadiag::sim::supported_simd_targets() : split(list);
            scalar_dataset = list != "all" && std::find(targets.begin(), targets.end(), "scalar") != targets.end();
        } else {
            args.push_back(argv[i]);
        }
    }
    int bench_argc = static_cast<int>(args.size());
    const emadiag::sim::SimdTarget chosen = emadiag::sim::simd_target();  // EMADIAG_SIMD, or the widest
    std::printf("CPU supports:");
    for (const auto& t : emadiag::sim::supported_simd_targets()) std::printf(" %s", t.c_str());
    std::printf("; batched path would run on %s (%d lanes x %d groups)%s\n", chosen.name.c_str(), chosen.lanes,
                chosen.groups, std::getenv(emadiag::sim::kSimdEnvVar) != nullptr ? " as EMADIAG_SIMD says" : "");
    if (targets.empty()) {
        targets = std::getenv(emadiag::sim::kSimdEnvVar) != nullptr ? std::vector<std::string>{chosen.name}
                                                                     : emadiag::sim::supported_simd_targets();
    }
    try {
        for (const auto& t : targets) emadiag::sim::set_simd_target(t);  // reject a bad name before any figure
    } catch (const std::exception& e) {
        std::fprintf(stderr, "sim_bench: %s\n", e.what());
        return 2;
    }

    // The scalar path (simulate) on each target too: on a CPU whose best is AVX2, simulate() runs
    // the AVX2 copy of the scalar step, so that is the figure such a machine gets.
    for (const auto& t : targets) {
        auto fn = [t](benchmark::State& state) { BM_ScalarStep(state, t); };
        benchmark::RegisterBenchmark(("BM_ScalarStep/" + t).c_str(), fn)->Unit(benchmark::kMillisecond);  // CPU time
    }
    for (const auto& t : targets) {
        auto fn = [t](benchmark::State& state) { BM_BatchStep(state, t); };
        benchmark::RegisterBenchmark(("BM_BatchStep/" + t).c_str(), fn)->Arg(1)->Unit(benchmark::kMillisecond);  // one core: CPU time
        benchmark::RegisterBenchmark(("BM_BatchStep/" + t).c_str(), fn)
            ->Arg(2)
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime();  // two cores: wall time
    }
    benchmark::Initialize(&bench_argc, args.data());
    Reporter reporter;
    benchmark::RunSpecifiedBenchmarks(&reporter);
    benchmark::Shutdown();

    // Ratios within this run: one core's batched throughput over the scalar path's on the same target
    // (what a CPU whose best target that is gets from simulate and from simulate_batch).
    std::printf("\n%-8s %-14s %16s %18s %19s %14s\n", "target", "lanes x groups", "scalar ns/step", "1 core ns/sim-step",
                "2 cores ns/sim-step", "x scalar (1c)");
    for (const auto& t : targets) {
        emadiag::sim::set_simd_target(t);
        const emadiag::sim::SimdTarget st = emadiag::sim::simd_target();
        const double scalar_s = reporter.figure("BM_ScalarStep/" + t);
        const double one = reporter.figure("BM_BatchStep/" + t + "/1");
        const double two = reporter.figure("BM_BatchStep/" + t + "/2/real_time");
        if (one <= 0.0 && scalar_s <= 0.0) continue;  // filtered out by --benchmark_filter
        std::printf("%-8s %6d x %-5d %16.3f %18.3f %19.3f %14.2f\n", t.c_str(), st.lanes, st.groups, scalar_s * 1e9,
                    one * 1e9, two * 1e9, scalar_s > 0.0 && one > 0.0 ? scalar_s / one : 0.0);
    }

    // The paper's dataset size, timed once on two threads per SIMD target (the scalar path only when
    // --simd names it: it takes minutes). The process CPU time says what the wall time would be on two
    // idle cores (CPU / 2) when other work shares the machine.
    const auto cs = configs(2000, 42);
    for (const auto& t : targets) {
        if (t == "scalar" && !scalar_dataset) continue;
        emadiag::sim::set_simd_target(t);
        const auto t0 = std::chrono::steady_clock::now();
        const std::clock_t c0 = std::clock();
        const auto r = emadiag::sim::simulate_batch(cs, 2);
        const double cpu_s = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
        const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf("paper dataset [%s]: %zu simulations x 0.5 s at 1 us (%.2e simulation-steps) in %.2f s wall on "
                    "2 threads (%.2f ns per simulation-step); CPU %.2f s (%.2f s on 2 idle cores)\n",
                    t.c_str(), r.size(), kStepsPerRun * 2000.0, wall_s, wall_s / (kStepsPerRun * 2000.0) * 1e9, cpu_s,
                    cpu_s / 2.0);
    }
    return 0;
}
