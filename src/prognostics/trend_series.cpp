#include "prognostics/trend_series.hpp"

#include "core/emadiag_error.hpp"
#include "estimation/estimator_id.hpp"
#include "prognostics/utc_time.hpp"

#include "emadiag/calc/inverse_variance.hpp"

#include <cmath>
#include <sstream>

namespace emadiag::prognostics {
namespace {

/// The database's text read by the one parser (estimation/estimator_id.hpp).
bool is_physics(const db::StoredFinding& f) {
    const auto id = parse_estimator_id(f.estimator);
    return id && id->method == EstimatorMethod::Physics;
}

std::string num(double v) {
    std::ostringstream os;
    os.precision(6);
    os << v;
    return os.str();
}

const db::StoredTestSession& deref(const db::StoredTestSession& s) { return s; }
const db::StoredTestSession& deref(const db::StoredTestSession* s) { return *s; }

template <typename Session>
std::vector<double> days_of(const std::vector<Session>& sessions) {
    std::vector<double> days;
    days.reserve(sessions.size());
    std::vector<std::string> problems;
    for (const auto& entry : sessions) {
        const db::StoredTestSession& s = deref(entry);
        std::string problem;
        const auto d = parse_utc_days(s.started_utc, problem);
        if (!d) {
            problems.push_back("test session " + std::to_string(s.session_id) + " started_utc \"" + s.started_utc + "\": " + problem);
            days.push_back(0);
        } else {
            days.push_back(*d);
        }
    }
    if (!problems.empty()) {
        std::string msg = std::to_string(problems.size()) + " test session(s) with an unusable start time";
        for (const auto& p : problems) msg += "; " + p;
        throw EmadiagError(msg);
    }
    return days;
}

template <typename Session>
ParameterSeries series_of(const std::vector<Session>& sessions, const std::vector<double>& days, const std::string& parameter,
                          double origin_days) {
    if (days.size() != sessions.size())
        throw EmadiagError("build_series: " + std::to_string(days.size()) + " times for " + std::to_string(sessions.size()) + " sessions");
    ParameterSeries out;
    out.parameter = parameter;
    std::vector<std::int64_t> skipped;
    for (std::size_t i = 0; i < sessions.size(); ++i) {
        const db::StoredTestSession& s = deref(sessions[i]);
        calc::InverseVarianceMean mean;
        TrendPoint p;
        std::vector<std::string> unusable;
        for (const auto& f : s.findings) {
            if (f.parameter != parameter) continue;
            if ((f.limit_kind == "max" || f.limit_kind == "min") && f.limit_value) {
                const TrendLimit l{f.limit_kind == "max" ? LimitSide::Max : LimitSide::Min, *f.limit_value, s.session_id};
                if (out.limit && (out.limit->side != l.side || out.limit->value != l.value) && out.limit->session_id != l.session_id) {
                    out.notes.push_back("the limit changed from " + std::string(to_string(out.limit->side)) + " " + num(out.limit->value) +
                                        " (session " + std::to_string(out.limit->session_id) + ") to " + to_string(l.side) + " " +
                                        num(l.value) + " (session " + std::to_string(l.session_id) + "); the most recent is used");
                }
                out.limit = l;
            }
            if (!is_physics(f) || !f.value) continue;
            // Inverse-variance weighting needs a positive finite standard error.
            if (!f.std_error || !calc::is_weightable(*f.std_error)) {
                unusable.push_back(f.estimator + " (value " + num(*f.value) + " without a positive standard error)");
                continue;
            }
            mean.add(*f.value, *f.std_error);
            p.estimators.push_back(f.estimator);
        }
        for (const auto& u : unusable)
            out.notes.push_back("session " + std::to_string(s.session_id) + ": " + parameter + " finding " + u + " not used");
        if (mean.sum_w == 0) {
            skipped.push_back(s.session_id);
            continue;
        }
        p.session_id = s.session_id;
        p.started_utc = s.started_utc;
        p.t_days = days[i] - origin_days;
        p.value = mean.mean();
        p.std_error = mean.std_error();
        out.points.push_back(std::move(p));
    }
    if (!skipped.empty()) {
        std::string ids;
        for (std::size_t i = 0; i < skipped.size(); ++i) ids += (i ? ", " : "") + std::to_string(skipped[i]);
        out.notes.push_back(std::to_string(skipped.size()) + " session(s) without a physics value of " + parameter +
                            " (not identifiable or not estimated) left out: " + ids);
    }
    return out;
}

}  // namespace

const char* to_string(LimitSide s) { return s == LimitSide::Max ? "max" : "min"; }

bool is_beyond(double value, const TrendLimit& limit) {
    return limit.side == LimitSide::Max ? value > limit.value : value < limit.value;
}

std::vector<double> session_days(const std::vector<db::StoredTestSession>& sessions) { return days_of(sessions); }
std::vector<double> session_days(const std::vector<const db::StoredTestSession*>& sessions) { return days_of(sessions); }

ParameterSeries build_series(const std::vector<db::StoredTestSession>& sessions, const std::vector<double>& days, const std::string& parameter,
                             double origin_days) {
    return series_of(sessions, days, parameter, origin_days);
}
ParameterSeries build_series(const std::vector<const db::StoredTestSession*>& sessions, const std::vector<double>& days,
                             const std::string& parameter, double origin_days) {
    return series_of(sessions, days, parameter, origin_days);
}

}  // namespace emadiag::prognostics
