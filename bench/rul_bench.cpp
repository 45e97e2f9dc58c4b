// How well `emadiag trend` predicts the remaining useful life (docs/trend-report.md): synthetic
// FDJ histories with a known truth and Gaussian noise of known se (prognostics/synthetic_history),
// fitted and projected exactly as the trend report does. Per noise level: the coverage of the 90 %
// RUL interval, the median |RUL error| of the point estimate, the median interval width and how
// often the log-linear model was chosen. Then the prognostic metrics users of NASA ProgPy expect
// (prognostics_metrics.hpp): over a longer history, predictions after every session from the 3rd on,
// alpha-lambda accuracy, relative accuracy and prognostic horizon (choices in docs/trend-report.md).
// No timing goals.
//   rul_bench [count [seed]]   (defaults 500, 1)
#include "prognostics/degradation_fit.hpp"
#include "prognostics/prognostics_metrics.hpp"
#include "prognostics/rul_estimate.hpp"
#include "prognostics/synthetic_history.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <optional>
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

/// The ProgPy metrics: alpha bounds +/-20 % of the true RUL, evaluated at lambda = 50 % of the life from
/// the first prediction to the true end of life, a prediction meeting them when half (beta) of its
/// Monte Carlo distribution lies within; the prognostic horizon uses the same alpha and beta.
constexpr double kAlpha = 0.2;
constexpr double kLambda = 0.5;
constexpr double kBeta = 0.5;
/// Profile histories: sessions every 30 days up to day 390, the last before the true end of life (day 400);
/// the first prediction after the 3rd session (kMinTrendPoints), day 60.
constexpr int kProfileSessions = 14;
constexpr double kTrueEolDays = 400.0;

/// The RUL distribution of one prediction: the same Monte Carlo as estimate_rul (rul_estimate.cpp, same
/// seed, same draws), kept whole because alpha-lambda asks what fraction lies within the bounds. Draws
/// that never cross within the horizon are +infinity, those that crossed before the last session 0.
std::vector<double> rul_draws(const pg::DegradationFit& fit, const pg::TrendLimit& limit, double t_last, const pg::RulOptions& o) {
    const Eigen::Matrix2d& c = fit.covariance;
    const double l11 = std::sqrt(std::max(0.0, c(0, 0)));
    const double l21 = l11 > 0 ? c(1, 0) / l11 : 0.0;
    const double l22 = std::sqrt(std::max(0.0, c(1, 1) - l21 * l21));
    pg::NormalSampler normal(o.seed);
    std::vector<double> rul(static_cast<std::size_t>(o.draws));
    for (auto& x : rul) {
        const double z1 = normal.next(), z2 = normal.next();
        const auto tc = pg::crossing_time(fit.model, fit.a + l11 * z1, fit.b + l21 * z1 + l22 * z2, limit);
        if (!tc || *tc > t_last + o.horizon_days) x = std::numeric_limits<double>::infinity();
        else x = std::max(0.0, *tc - t_last);
    }
    return rul;
}

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

struct MetricsRow {
    int alpha_lambda_met = 0, alpha_lambda_evaluated = 0, horizon_met = 0;
    std::vector<double> fraction_within, relative_accuracy, horizon_days;
    int no_point_estimate = 0;
};

MetricsRow run_metrics(int count, std::uint64_t seed, double se, const std::function<double(double)>& truth) {
    MetricsRow row;
    pg::NormalSampler noise(seed);
    const pg::SyntheticHistory h{kProfileSessions, kDaysBetween, se};
    const pg::TrendLimit limit{pg::LimitSide::Max, kLimitNm, kProfileSessions};
    for (int i = 0; i < count; ++i) {
        const auto all = pg::synthetic_points(h, truth, &noise);
        std::vector<pg::RulPrediction> profile;
        for (int k = pg::kMinTrendPoints; k <= kProfileSessions; ++k) {
            const std::vector<pg::TrendPoint> pts(all.begin(), all.begin() + k);
            const pg::ModelFits m = pg::fit_models(pts);
            pg::RulOptions o;
            o.seed = seed * 1000003ULL + static_cast<std::uint64_t>(i) * 100 + static_cast<std::uint64_t>(k);
            const pg::RulEstimate r = pg::estimate_rul(pts, m.chosen(), limit, o);
            pg::RulPrediction p;
            p.t = pts.back().t_days;
            p.rul_point = r.rul_days;
            p.rul_samples = r.status == pg::RulStatus::AlreadyExceeded ? std::vector<double>{0.0}
                                                                       : rul_draws(m.chosen(), limit, p.t, o);
            profile.push_back(std::move(p));
        }
        const pg::AlphaLambdaResult al = pg::alpha_lambda(profile, kTrueEolDays, kLambda, kAlpha, kBeta);
        if (al.evaluated) {
            ++row.alpha_lambda_evaluated;
            if (al.met) ++row.alpha_lambda_met;
            row.fraction_within.push_back(al.fraction_within);
            const auto& at = *std::find_if(profile.begin(), profile.end(), [&](const pg::RulPrediction& p) { return p.t == al.t_evaluated; });
            if (at.rul_point) row.relative_accuracy.push_back(pg::relative_accuracy(*at.rul_point, al.true_rul));
            else ++row.no_point_estimate;
        }
        const auto ph = pg::prognostic_horizon(profile, kTrueEolDays, kAlpha, kBeta);
        if (ph) ++row.horizon_met;
        row.horizon_days.push_back(ph.value_or(0.0));
    }
    return row;
}

double mean(const std::vector<double>& v) {
    if (v.empty()) return NAN;
    double s = 0;
    for (const double x : v) s += x;
    return s / static_cast<double>(v.size());
}

void print_metrics(const char* truth, double se, int count, const MetricsRow& r) {
    std::printf("%-12s %8.5f %12.1f %%  %12.2f  %8.3f  %8.3f  %8d  %10.0f  %8.1f %%\n", truth, se, 100.0 * r.alpha_lambda_met / count,
                median(r.fraction_within), mean(r.relative_accuracy), median(r.relative_accuracy), r.no_point_estimate, median(r.horizon_days),
                100.0 * r.horizon_met / count);
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

    std::printf("\nProgPy metrics (prognostics_metrics.hpp): %d histories per row, %d sessions %g days apart (day 0 to %g), true end of\n"
                "life day %g; a prediction after every session from session %d (day %g, t_P) on, each with its %d Monte Carlo draws.\n"
                "alpha-lambda: alpha %g, lambda %g (t_lambda = t_P + lambda (EoL - t_P) = day %g; the prediction at or after it, ProgPy's\n"
                "rule), met when a fraction beta = %g of the draws lies within +/-alpha of the true RUL. RA = 1 - |r* - r| / r* of the\n"
                "point RUL at that prediction. PH = EoL - t of the first prediction meeting the same alpha/beta criterion (0 when none).\n\n",
                count, kProfileSessions, kDaysBetween, kDaysBetween * (kProfileSessions - 1), kTrueEolDays, pg::kMinTrendPoints,
                kDaysBetween * (pg::kMinTrendPoints - 1), pg::kDefaultMonteCarloDraws, kAlpha, kLambda,
                kDaysBetween * (pg::kMinTrendPoints - 1) + kLambda * (kTrueEolDays - kDaysBetween * (pg::kMinTrendPoints - 1)), kBeta);
    std::printf("%-12s %8s %14s  %12s  %8s  %8s  %8s  %10s  %10s\n", "truth", "se [N m]", "alpha-lambda", "med frac in", "mean RA",
                "med RA", "no point", "med PH d", "PH met");
    for (const double se : {0.00025, 0.0005, 0.001, 0.002}) {
        print_metrics("linear", se, count, run_metrics(count, seed, se, [](double t) { return kStartNm + kRateNmPerDay * t; }));
    }
    for (const double se : {0.0005, 0.001}) {
        print_metrics("exponential", se, count, run_metrics(count, seed, se, [](double t) { return kStartNm * std::exp(kGrowthPerDay * t); }));
    }
    return 0;
}
