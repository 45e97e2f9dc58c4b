#pragma once
// UTC times of test sessions as days on a continuous axis (proleptic Gregorian calendar, no leap
// seconds), and back to calendar dates for the report.
#include "emadiag/calc/civil_days.hpp"

#include <optional>
#include <string>

namespace emadiag::prognostics {

inline constexpr double kSecondsPerDay = calc::kSecondsPerDay;

/// Days since 1970-01-01T00:00:00Z of "YYYY-MM-DDThh:mm:ss" with an optional fraction (".123") and
/// an optional "Z"; nothing else (no offsets, no date alone). Empty when `text` is not of that form
/// or names no real time (month 13, 30 February, hour 24, ...); `problem` then says why.
[[nodiscard]] std::optional<double> parse_utc_days(const std::string& text, std::string& problem);

/// parse_utc_days, throwing EmadiagError naming `what` (e.g. "test session 7 started_utc"), the value
/// and the expected form.
[[nodiscard]] double parse_utc_days_or_throw(const std::string& text, const std::string& what);

/// "YYYY-MM-DD" of the day containing `days_since_epoch`.
[[nodiscard]] std::string format_utc_date(double days_since_epoch);

/// "YYYY-MM-DDThh:mm:ssZ" (to the second, rounded to the nearest).
[[nodiscard]] std::string format_utc_time(double days_since_epoch);

/// The system clock now, as format_utc_time (when a report was made).
[[nodiscard]] std::string now_utc_time();

}  // namespace emadiag::prognostics
