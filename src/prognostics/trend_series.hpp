#pragma once
// Step 1 of a trend: one measurement of a parameter per test session, on a time axis.
// A session's measurement combines its physics findings of the parameter that have a value (e.g.
// physics:dyn and physics:brk FDJ) by their inverse-variance weighted mean:
//   y = sum(w_i y_i) / sum(w_i),  se = 1 / sqrt(sum(w_i)),  w_i = 1 / se_i^2
// (the network findings are the cross-check of the verdict, not a measurement here). Sessions
// without such a finding are left out of that parameter's series, with a note.
#include "emadiag/db/session_store.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace emadiag::prognostics {

/// Which side of its limit a parameter must stay on: friction at most (max), efficiency at least (min).
enum class LimitSide { Max, Min };
[[nodiscard]] const char* to_string(LimitSide s);

struct TrendLimit {
    LimitSide side = LimitSide::Max;
    double value = 0;              ///< in the parameter's unit
    std::int64_t session_id = 0;   ///< the most recent session whose findings gave it
};

/// True when `value` is past the limit (a value exactly at the limit is not).
[[nodiscard]] bool is_beyond(double value, const TrendLimit& limit);

struct TrendPoint {
    std::int64_t session_id = 0;
    std::string started_utc;
    double t_days = 0;     ///< days since the tail's first session
    double value = 0;      ///< the combined measurement, in the parameter's unit
    double std_error = 0;  ///< its 1-se uncertainty
    std::vector<std::string> estimators;  ///< the findings combined, e.g. "physics:brk", "physics:dyn"
};

struct ParameterSeries {
    std::string parameter;
    std::vector<TrendPoint> points;   ///< in session order
    std::optional<TrendLimit> limit;  ///< the most recent limit of the parameter in the findings
    std::vector<std::string> notes;   ///< sessions left out and why, limit changes
};

/// Days since 1970 of each session's started_utc. Throws EmadiagError listing every session whose
/// started_utc is not "YYYY-MM-DDThh:mm:ss[.fff][Z]", naming its id and value.
[[nodiscard]] std::vector<double> session_days(const std::vector<db::StoredTestSession>& sessions);
/// The same over sessions held elsewhere (the report's views point into one list, no copies).
[[nodiscard]] std::vector<double> session_days(const std::vector<const db::StoredTestSession*>& sessions);

/// The series of `parameter` over `sessions` (in the order given), t_days relative to origin_days
/// (days since 1970). `days` is session_days(sessions).
[[nodiscard]] ParameterSeries build_series(const std::vector<db::StoredTestSession>& sessions, const std::vector<double>& days,
                                           const std::string& parameter, double origin_days);
/// The same over sessions held elsewhere (the same series as over copies of them).
[[nodiscard]] ParameterSeries build_series(const std::vector<const db::StoredTestSession*>& sessions, const std::vector<double>& days,
                                           const std::string& parameter, double origin_days);

}  // namespace emadiag::prognostics
