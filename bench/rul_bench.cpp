// How well `emadiag trend` predicts the remaining useful life (docs/trend-report.md): synthetic
// FDJ histories with a known truth and Gaussian noise of known se (prognostics/synthetic_history),
// fitted and projected exactly as the trend report does. Per noise level: the coverage of the 90 %
// RUL interval, the median |RUL error| of the point estimate, the median interval width and how
// often the log-linear model was chosen. No timing goals.
//   rul_bench [count [seed]]   (defaults 500, 1)
#include "prognostics/degradation_fit.hpp"
#include "prognostics/rul_estimate.hpp"
#include "prognostics/synthetic_history.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

namespace {

namespace pg = emadiag::prognostics;

constexpr int kDefaultCount = 500;
constexpr std::uint64_t kDefaultSeed = 1;
constexpr int kSessions = 8;
constexpr double kDaysBetween = 30.0;
constexpr double kStartNm = 0.08;
constexpr double kLimitNm = 0.096;
/// Linear truth: 0.004 N m per 100 days, crossing at day 400 (RUL 190 days after day 210).
constexpr double kRateNmPerDay = 4e-5;
/// Exponential truth through the same start and crossing: 0.08 e^(k t), k = ln(0.096/0.08) / 400.
const double kGrowthPerDay = std::log(kLimitNm / kStartNm) / 400.0;

double median(std::vector<double> v) {
    if (v.empty()) return NAN;
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct Row {
    int covered = 0, with_estimate = 0, upper_beyond = 0, log_linear = 0, exceeded = 0;
    std::vector<double> abs_error, width;
};

Row run(int count, std::uint64_t seed, double se, const std::function<double(double)>& truth, double true_crossing) {
    Row row;
    pg::NormalSampler noise(seed);
    const pg::SyntheticHistory h{kSessions, kDaysBetween, se};
    const pg::TrendLimit limit{pg::LimitSide::Max, kLimitNm, kSessions};
    for (int i = 0; i < count; ++i) {
        const auto pts = pg::synthetic_points(h, truth, &noise);
        const double true_rul = true_crossing - pts.back().t_days;
        const pg::ModelFits m = pg::fit_models(pts);
        if (m.choice.model == pg::DegradationModel::LogLinear) ++row.log_linear;
        pg::RulOptions o;
        o.seed = seed * 1000003ULL + static_cast<std::uint64_t>(i);
        const pg::RulEstimate r = pg::estimate_rul(pts, m.chosen(), limit, o);
        if (r.status == pg::RulStatus::AlreadyExceeded) ++row.exceeded;
        if (r.rul_days) {
            ++row.with_estimate;
            row.abs_error.push_back(std::abs(*r.rul_days - true_rul));
        }
        const bool lo_ok = r.rul_lower_days && *r.rul_lower_days <= true_rul;
        const bool hi_ok = !r.rul_upper_days || true_rul <= *r.rul_upper_days;
        if (r.interval_computed && lo_ok && hi_ok) ++row.covered;
        if (r.interval_computed && !r.rul_upper_days) ++row.upper_beyond;
        if (r.rul_lower_days && r.rul_upper_days) row.width.push_back(*r.rul_upper_days - *r.rul_lower_days);
    }
    return row;
}

void print(const char* truth, double se, int count, const Row& r) {
    std::printf("%-12s %8.5f %10.1f %%  %10.1f  %12.1f  %9d  %10d  %8d\n", truth, se, 100.0 * r.covered / count, median(r.abs_error),
                median(r.width), r.upper_beyond, r.log_linear, r.exceeded);
}

}  // namespace

int main(int argc, char** argv) {
    const int count = argc > 1 ? std::atoi(argv[1]) : kDefaultCount;
    const std::uint64_t seed = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : kDefaultSeed;
    if (count <= 0) {
        std::fprintf(stderr, "rul_bench: count %d must be positive\n", count);
        return 2;
    }
    std::printf("rul_bench: %d histories per row, seed %llu; %d sessions %g days apart, FDJ %g N m at day 0, limit %g N m,\n"
                "true crossing at day 400 (true RUL 190 days); 90 %% intervals from %d Monte Carlo draws, horizon %g days\n\n",
                count, static_cast<unsigned long long>(seed), kSessions, kDaysBetween, kStartNm, kLimitNm, pg::kDefaultMonteCarloDraws,
                pg::kDefaultHorizonDays);
    std::printf("%-12s %8s %12s  %10s  %12s  %9s  %10s  %8s\n", "truth", "se [N m]", "coverage", "med |err| d", "med width d",
                "upper>hor", "log-linear", "exceeded");
    for (const double se : {0.00025, 0.0005, 0.001, 0.002}) {
        print("linear", se, count, run(count, seed, se, [](double t) { return kStartNm + kRateNmPerDay * t; }, 400.0));
    }
    for (const double se : {0.0005, 0.001}) {
        print("exponential", se, count, run(count, seed, se, [](double t) { return kStartNm * std::exp(kGrowthPerDay * t); }, 400.0));
    }
    return 0;
}
