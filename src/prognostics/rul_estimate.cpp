#include "prognostics/rul_estimate.hpp"

#include "core/emadiag_error.hpp"
#include "prognostics/normal_sampler.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace emadiag::prognostics {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string num(double v, int digits = 4) {
    std::ostringstream os;
    os.precision(digits);
    os << v;
    return os.str();
}

std::string days(double v) {
    std::ostringstream os;
    os.setf(std::ios::fixed);
    os.precision(0);
    os << v;
    return os.str();
}

/// Percentile by linear interpolation between order statistics (Hyndman & Fan type 7); +inf when
/// it touches an infinite value. `v` is partitioned in place from index `from` on (std::nth_element:
/// the two order statistics it needs, the same values a full sort gives); `from` is the first index
/// not yet fixed by an earlier, lower quantile.
double quantile(std::vector<double>& v, double q, std::size_t from = 0) {
    const double h = q * static_cast<double>(v.size() - 1);
    const auto lo = static_cast<std::size_t>(std::floor(h));
    const std::size_t hi = std::min(lo + 1, v.size() - 1);
    const auto first = v.begin() + static_cast<std::ptrdiff_t>(std::min(from, lo));
    std::nth_element(first, v.begin() + static_cast<std::ptrdiff_t>(lo), v.end());
    // After nth_element every element past lo is >= v[lo]: the next order statistic is their minimum.
    const double x_lo = v[lo];
    const double x_hi = hi == lo ? x_lo : *std::min_element(v.begin() + static_cast<std::ptrdiff_t>(hi), v.end());
    if (std::isinf(x_lo) || std::isinf(x_hi)) return kInf;
    return x_lo + (h - static_cast<double>(lo)) * (x_hi - x_lo);
}

/// The index past the lower order statistic quantile(v, q) fixed.
std::size_t fixed_after(const std::vector<double>& v, double q) {
    return static_cast<std::size_t>(std::floor(q * static_cast<double>(v.size() - 1))) + 1;
}

}  // namespace

const char* to_string(RulStatus s) {
    switch (s) {
        case RulStatus::InsufficientData: return "insufficient_data";
        case RulStatus::NoLimit: return "no_limit";
        case RulStatus::AlreadyExceeded: return "already_exceeded";
        case RulStatus::NoCrossing: return "no_crossing";
        case RulStatus::Predicted: return "predicted";
    }
    return "?";
}

void check(const RulOptions& o) {
    if (!(o.horizon_days > 0) || !(o.horizon_days <= kMaxHorizonDays))
        throw EmadiagError("horizon_days " + num(o.horizon_days) + " is not in (0, " + num(kMaxHorizonDays, 6) + "] days");
    if (o.draws < kMinMonteCarloDraws || o.draws > kMaxMonteCarloDraws)
        throw EmadiagError("Monte Carlo draws " + std::to_string(o.draws) + " is not in [" + std::to_string(kMinMonteCarloDraws) + ", " +
                           std::to_string(kMaxMonteCarloDraws) + "]");
}

std::optional<double> crossing_time(DegradationModel model, double a, double b, const TrendLimit& limit) {
    // Towards the limit: rising to a maximum, falling to a minimum (e^x is increasing, so the sign of
    // b decides for both models).
    const bool towards = limit.side == LimitSide::Max ? b > 0 : b < 0;
    if (!towards) return std::nullopt;
    if (model == DegradationModel::Linear) return (limit.value - a) / b;
    if (!(limit.value > 0)) return std::nullopt;
    return (std::log(limit.value) - a) / b;
}

RulEstimate estimate_rul(const std::vector<TrendPoint>& points, const DegradationFit& fit, const std::optional<TrendLimit>& limit,
                         const RulOptions& options) {
    check(options);
    RulEstimate r;
    r.horizon_days = options.horizon_days;
    r.seed = options.seed;
    if (!points.empty()) r.t_last_days = points.back().t_days;
    if (limit && !points.empty() && is_beyond(points.back().value, *limit)) {
        const TrendPoint& last = points.back();
        r.status = RulStatus::AlreadyExceeded;
        r.exceeded_session_id = last.session_id;
        r.rul_days = 0.0;
        r.summary = "limit already exceeded at session " + std::to_string(last.session_id) + " (" + num(last.value) + " against " +
                    to_string(limit->side) + " " + num(limit->value) + ")";
        if (fit.fitted) r.crossing_t_days = crossing_time(fit.model, fit.a, fit.b, *limit);
        return r;
    }
    if (!fit.fitted) {
        r.status = RulStatus::InsufficientData;
        r.summary = fit.note;
        return r;
    }
    if (!limit) {
        r.status = RulStatus::NoLimit;
        r.summary = "no limit in the findings; no crossing to predict";
        return r;
    }

    // The fitted mean's crossing.
    const double t_end = r.t_last_days + options.horizon_days;
    const auto t_cross = crossing_time(fit.model, fit.a, fit.b, *limit);
    if (t_cross && *t_cross <= t_end) {
        r.status = RulStatus::Predicted;
        r.crossing_t_days = t_cross;
        r.rul_days = std::max(0.0, *t_cross - r.t_last_days);
        r.summary = *t_cross < r.t_last_days
                        ? "the fitted trend crossed the limit at day " + days(*t_cross) + ", before the last session (day " +
                              days(r.t_last_days) + "): RUL 0"
                        : "crossing predicted at day " + days(*t_cross) + ", RUL " + days(*r.rul_days) + " days";
    } else {
        r.status = RulStatus::NoCrossing;
        r.summary = "no crossing predicted within the horizon (" + days(options.horizon_days) + " days)" +
                    (t_cross ? "" : ": the trend is flat or moving away from the limit");
    }

    // Monte Carlo over (a, b) ~ N(fit, covariance): (a, b) = mean + L z with L L' = covariance
    // (Cholesky of the 2 x 2, written out; a singular direction just gets no spread).
    const Eigen::Matrix2d& c = fit.covariance;
    const double l11 = std::sqrt(std::max(0.0, c(0, 0)));
    const double l21 = l11 > 0 ? c(1, 0) / l11 : 0.0;
    const double l22 = std::sqrt(std::max(0.0, c(1, 1) - l21 * l21));
    NormalSampler normal(options.seed);
    std::vector<double> rul(static_cast<std::size_t>(options.draws));
    for (auto& x : rul) {
        const double z1 = normal.next(), z2 = normal.next();
        const double a = fit.a + l11 * z1;
        const double b = fit.b + l21 * z1 + l22 * z2;
        const auto tc = crossing_time(fit.model, a, b, *limit);
        if (!tc || *tc > t_end) {
            x = kInf;
            ++r.draws_beyond_horizon;
        } else if (*tc < r.t_last_days) {
            x = 0.0;
            ++r.draws_already_crossed;
        } else {
            x = *tc - r.t_last_days;
        }
    }
    r.draws = options.draws;
    r.interval_computed = true;
    // Two order statistics each, by selection rather than a full sort (same values).
    static_assert(kRulLowerQuantile < kRulUpperQuantile);
    const double lo = quantile(rul, kRulLowerQuantile);
    const double hi = quantile(rul, kRulUpperQuantile, fixed_after(rul, kRulLowerQuantile));
    if (std::isfinite(lo)) r.rul_lower_days = lo;
    if (std::isfinite(hi)) r.rul_upper_days = hi;
    return r;
}

}  // namespace emadiag::prognostics
