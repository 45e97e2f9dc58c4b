#pragma once
// Days on a continuous axis from civil dates (proleptic Gregorian calendar, no leap seconds): the one
// date arithmetic of the station's summary tables (maintenance_db) and of the trends (prognostics).
// Header-only, below every library, like include/emadiag/io/.
#include <cstdint>

namespace emadiag::calc {

inline constexpr double kSecondsPerDay = 86400.0;

/// Days from 1970-01-01 to y-m-d (proleptic Gregorian): H. Hinnant, "chrono-Compatible Low-Level
/// Date Algorithms", days_from_civil.
[[nodiscard]] constexpr std::int64_t days_from_civil(std::int64_t y, int m, int d) {
    y -= m <= 2 ? 1 : 0;
    const std::int64_t era = (y >= 0 ? y : y - 399) / 400;
    const std::int64_t yoe = y - era * 400;
    const std::int64_t doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
    const std::int64_t doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    return era * 146097 + doe - 719468;
}

/// Days since 1970-01-01T00:00:00 of y-m-d and `seconds` into that day.
[[nodiscard]] constexpr double days_since_epoch(std::int64_t y, int m, int d, double seconds) {
    return static_cast<double>(days_from_civil(y, m, d)) + seconds / kSecondsPerDay;
}

}  // namespace emadiag::calc
