// How often the technician's verdict is wrong: false accepts (a transmission beyond a limit
// declared SERVICEABLE) and false rejects (one within every limit declared UNSERVICEABLE), and how
// often it asks for a retest (INCONCLUSIVE). The ground routine of `emadiag test-run` (DYN then BRK,
// case A, noise typical: the quantised signals the CAN bus carries) on units whose FDJ and FSJ are
// drawn uniformly from nominal +/-40 %, twice the section-8 envelope, so that about half of them
// are beyond a limit. Verdicts against the default limits (the section-8 envelope).
//   verdict_bench [count [seed]]   (defaults 400, 11)
#include "core/sim_run.hpp"
#include "diagnosis/health_limits.hpp"
#include "diagnosis/verdict.hpp"
#include "emadiag/sim/simulator.hpp"
#include "estimation/dataset.hpp"
#include "estimation/run_estimator.hpp"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

namespace {

namespace sim = emadiag::sim;
using namespace emadiag;

constexpr int kDefaultCount = 400;
constexpr std::uint64_t kDefaultSeed = 11;
constexpr double kDrawHalfWidth = 0.40;   // nominal +/-40 %
constexpr double kNearLimitRel = 0.03;    // "near a limit": within 3 % of it

}  // namespace

int main(int argc, char** argv) {
    const int count = argc > 1 ? std::atoi(argv[1]) : kDefaultCount;
    const std::uint64_t seed = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : kDefaultSeed;
    if (count <= 0) {
        std::fprintf(stderr, "usage: verdict_bench [count [seed]]\n");
        return 2;
    }
    const HealthLimits limits = HealthLimits::datasheet_envelope();
    const double fdj_max = limits.find(kParamFdj)->limit, fsj_max = limits.find(kParamFsj)->limit;
    const sim::EmaParams nominal = sim::EmaParams::datasheet();
    std::mt19937_64 rng(seed);
    std::vector<sim::SimConfig> configs[2];  // DYN, BRK (a batch shares its sequence)
    std::vector<std::pair<double, double>> truth;
    for (int i = 0; i < count; ++i) {
        const double fdj = nominal.fdj_nm * (1 - kDrawHalfWidth + 2 * kDrawHalfWidth * uniform01(rng()));
        double fsj = nominal.fsj_nm * (1 - kDrawHalfWidth + 2 * kDrawHalfWidth * uniform01(rng()));
        if (fsj < fdj) fsj = fdj;  // static friction is never below dynamic (the simulator requires it)
        truth.emplace_back(fdj, fsj);
        for (int k = 0; k < 2; ++k) {
            sim::SimConfig c;
            c.params.fdj_nm = fdj;
            c.params.fsj_nm = fsj;
            c.load_case = sim::LoadCase::A;
            c.noise = sim::NoiseProfile::Typical;
            c.seed = seed * 1000003ULL + static_cast<std::uint64_t>(i);
            c.sequence = k == 0 ? sim::Sequence::Dyn : sim::Sequence::Brk;
            configs[k].push_back(c);
        }
    }
    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<sim::SimResult> results[2] = {sim::simulate_batch(configs[0], 2), sim::simulate_batch(configs[1], 2)};
    // counts[truth][verdict]; truth 0 = within every limit, 1 = beyond one.
    int counts[2][4] = {{0, 0, 0, 0}, {0, 0, 0, 0}};
    int near = 0, near_inconclusive = 0, far = 0, far_inconclusive = 0, estimate_errors = 0;
    for (int i = 0; i < count; ++i) {
        std::vector<AssessedRun> runs;
        for (int k = 0; k < 2; ++k) {
            const auto j = static_cast<std::size_t>(i);
            AssessedRun a;
            a.sequence = k == 0 ? sim::Sequence::Dyn : sim::Sequence::Brk;
            a.valid = true;
            try {
                a.estimates = estimate_run(check_run(make_run(configs[k][j], results[k][j])));
            } catch (const std::exception& e) {
                a.valid = false;
                a.invalid_reason = e.what();
                ++estimate_errors;
            }
            runs.push_back(std::move(a));
        }
        const Assessment as = assess(runs, limits);
        const auto [fdj, fsj] = truth[static_cast<std::size_t>(i)];
        const int beyond = (fdj > fdj_max || fsj > fsj_max) ? 1 : 0;
        ++counts[beyond][static_cast<int>(as.verdict)];
        const bool is_near = std::abs(fdj / fdj_max - 1) < kNearLimitRel || std::abs(fsj / fsj_max - 1) < kNearLimitRel;
        (is_near ? near : far) += 1;
        if (as.verdict == Verdict::Inconclusive) (is_near ? near_inconclusive : far_inconclusive) += 1;
    }
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("verdict_bench: %d units, seed %llu, FDJ and FSJ uniform in nominal +/-%.0f %%, case A, noise typical, DYN + BRK\n",
                count, static_cast<unsigned long long>(seed), kDrawHalfWidth * 100);
    std::printf("limits: FDJ <= %.4g N m, FSJ <= %.4g N m (%s)\n", fdj_max, fsj_max, limits.source.c_str());
    std::printf("%-28s %12s %14s %13s %8s\n", "truth \\ verdict", "SERVICEABLE", "UNSERVICEABLE", "INCONCLUSIVE", "NO_TEST");
    const char* names[2] = {"within every limit", "beyond a limit"};
    for (int t = 0; t < 2; ++t)
        std::printf("%-28s %12d %14d %13d %8d\n", names[t], counts[t][0], counts[t][1], counts[t][2], counts[t][3]);
    const int n_ok = counts[0][0] + counts[0][1] + counts[0][2] + counts[0][3];
    const int n_bad = counts[1][0] + counts[1][1] + counts[1][2] + counts[1][3];
    std::printf("false accept (beyond -> SERVICEABLE): %d of %d (%.2f %%)\n", counts[1][0], n_bad, n_bad ? 100.0 * counts[1][0] / n_bad : 0.0);
    std::printf("false reject (within -> UNSERVICEABLE): %d of %d (%.2f %%)\n", counts[0][1], n_ok, n_ok ? 100.0 * counts[0][1] / n_ok : 0.0);
    std::printf("INCONCLUSIVE: %d of %d units within %.0f %% of a limit, %d of %d further away\n", near_inconclusive, near,
                kNearLimitRel * 100, far_inconclusive, far);
    std::printf("runs the estimators refused: %d; %.1f s on 2 threads (simulation) + 1 (estimation)\n", estimate_errors, secs);
    return 0;
}
