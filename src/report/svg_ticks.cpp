#include "report/svg_plot.hpp"

#include "core/emadiag_error.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <sstream>

// The axes' ticks of svg_plot.hpp: nice numbers and calendar dates.

namespace emadiag::report {
namespace {

/// Dates further than this from 1970 are not dates (about 27 000 years).
constexpr double kMaxDateDays = 1e7;
constexpr double kDaysPerMonth = 30.436875;
constexpr double kDaysPerYear = 365.2425;
constexpr double kMinutesPerDay = 1440.0;
/// Spans shorter than this get ticks at times of day ("2026-03-06 12:00").
constexpr double kMinDateTickSpanDays = 3.0;

/// Heckbert, "Nice numbers for graph labels", Graphics Gems (1990): 1, 2, 5 or 10 times a power of 10.
double nice_number(double x, bool round) {
    const double exponent = std::floor(std::log10(x));
    const double fraction = x / std::pow(10.0, exponent);
    double nice = 10;
    if (round) {
        if (fraction < 1.5) nice = 1;
        else if (fraction < 3) nice = 2;
        else if (fraction < 7) nice = 5;
    } else {
        if (fraction <= 1) nice = 1;
        else if (fraction <= 2) nice = 2;
        else if (fraction <= 5) nice = 5;
    }
    return nice * std::pow(10.0, exponent);
}

// Howard Hinnant's civil calendar algorithms (proleptic Gregorian), days since 1970-01-01.
struct Civil {
    std::int64_t year;
    int month, day;
};

Civil civil_from_days(std::int64_t z) {
    z += 719468;
    const std::int64_t era = (z >= 0 ? z : z - 146096) / 146097;
    const auto doe = static_cast<unsigned>(z - era * 146097);
    const unsigned yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
    const std::int64_t y = static_cast<std::int64_t>(yoe) + era * 400;
    const unsigned doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    const unsigned mp = (5 * doy + 2) / 153;
    const unsigned d = doy - (153 * mp + 2) / 5 + 1;
    const unsigned m = mp < 10 ? mp + 3 : mp - 9;
    return {y + (m <= 2 ? 1 : 0), static_cast<int>(m), static_cast<int>(d)};
}

std::int64_t days_from_civil(std::int64_t y, int m, int d) {
    y -= m <= 2 ? 1 : 0;
    const std::int64_t era = (y >= 0 ? y : y - 399) / 400;
    const auto yoe = static_cast<unsigned>(y - era * 400);
    const unsigned doy = (153 * static_cast<unsigned>(m > 2 ? m - 3 : m + 9) + 2) / 5 + static_cast<unsigned>(d) - 1;
    const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    return era * 146097 + static_cast<std::int64_t>(doe) - 719468;
}

std::string date_label(std::int64_t days, int parts) {
    const Civil c = civil_from_days(days);
    char buf[48];
    if (parts == 3) std::snprintf(buf, sizeof buf, "%04lld-%02d-%02d", static_cast<long long>(c.year), c.month, c.day);
    else if (parts == 2) std::snprintf(buf, sizeof buf, "%04lld-%02d", static_cast<long long>(c.year), c.month);
    else std::snprintf(buf, sizeof buf, "%04lld", static_cast<long long>(c.year));
    return buf;
}

}  // namespace

std::vector<double> nice_ticks(double lo, double hi, int target) {
    if (!std::isfinite(lo) || !std::isfinite(hi) || !(lo < hi)) {
        std::ostringstream os;
        os << "nice_ticks: range [" << lo << ", " << hi << "] must be finite with lo < hi";
        throw EmadiagError(os.str());
    }
    if (target < 2) throw EmadiagError("nice_ticks: target " + std::to_string(target) + " must be at least 2");
    const double step = nice_number(nice_number(hi - lo, false) / (target - 1), true);
    const double first = std::ceil(lo / step - 1e-9);
    std::vector<double> ticks;
    for (double k = first;; k += 1) {
        const double t = k * step;
        if (t > hi + step * 1e-9) break;
        ticks.push_back(std::abs(t) < step * 1e-9 ? 0.0 : t);
    }
    return ticks;
}

std::string format_tick(double value, double step) {
    char buf[64];
    const double magnitude = std::max(std::abs(value), std::abs(step));
    const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(std::abs(step)) + 1e-9)));
    if (magnitude >= 1e7 || decimals > 6) {
        std::snprintf(buf, sizeof buf, "%.3g", value);
    } else {
        std::snprintf(buf, sizeof buf, "%.*f", decimals, value);
    }
    std::string s = buf;
    if (s.size() > 1 && s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);  // "-0.0" -> "0.0"
    return s;
}

std::vector<DateTick> date_ticks(double lo, double hi, int target) {
    if (!std::isfinite(lo) || !std::isfinite(hi) || !(lo < hi)) {
        std::ostringstream os;
        os << "date_ticks: range [" << lo << ", " << hi << "] must be finite with lo < hi";
        throw EmadiagError(os.str());
    }
    if (std::abs(lo) > kMaxDateDays || std::abs(hi) > kMaxDateDays) {
        std::ostringstream os;
        os << "date_ticks: range [" << lo << ", " << hi << "] days since 1970 is not a range of dates (beyond +/-" << kMaxDateDays << " days)";
        throw EmadiagError(os.str());
    }
    if (target < 2) throw EmadiagError("date_ticks: target " + std::to_string(target) + " must be at least 2");
    const double wanted_step = (hi - lo) / (target - 1);
    std::vector<DateTick> ticks;
    if (hi - lo < kMinDateTickSpanDays) {
        // Less than a few days: times of day, every 1, 2, 5, 10, 15 or 30 minutes or 1, 2, 3, 6, 12 or 24 hours.
        long long step_min = 1440;
        for (const long long m : {1LL, 2LL, 5LL, 10LL, 15LL, 30LL, 60LL, 120LL, 180LL, 360LL, 720LL, 1440LL}) {
            if (static_cast<double>(m) >= wanted_step * kMinutesPerDay) {
                step_min = m;
                break;
            }
        }
        const auto first = static_cast<long long>(std::ceil(lo * kMinutesPerDay / static_cast<double>(step_min) - 1e-9));
        for (long long k = first;; ++k) {
            const long long minutes = k * step_min;  // since 1970-01-01T00:00
            const double days = static_cast<double>(minutes) / kMinutesPerDay;
            if (days > hi + 1e-12) break;
            const long long per_day = static_cast<long long>(kMinutesPerDay);
            const std::int64_t day = minutes >= 0 ? minutes / per_day : -((-minutes + per_day - 1) / per_day);
            const long long minute = minutes - day * per_day;
            char hm[48];
            std::snprintf(hm, sizeof hm, " %02lld:%02lld", minute / 60, minute % 60);
            ticks.push_back({days, date_label(day, 3) + hm});
        }
        return ticks;
    }
    const auto first_day = static_cast<std::int64_t>(std::ceil(lo));
    const auto last_day = static_cast<std::int64_t>(std::floor(hi));
    if (wanted_step < 0.5 * kDaysPerMonth) {
        std::int64_t step = 14;
        for (const std::int64_t s : {1, 2, 5, 7, 14}) {
            if (static_cast<double>(s) >= wanted_step) {
                step = s;
                break;
            }
        }
        // Whole days; multiples of 7 from a Monday (1970-01-05) for weekly steps.
        const std::int64_t anchor = step % 7 == 0 ? 4 : 0;
        std::int64_t d = first_day + (((anchor - first_day) % step) + step) % step;
        for (; d <= last_day; d += step) ticks.push_back({static_cast<double>(d), date_label(d, 3)});
    } else if (wanted_step < 8 * kDaysPerMonth) {
        int months = 6;
        for (const int m : {1, 2, 3, 6}) {
            if (m * kDaysPerMonth >= wanted_step) {
                months = m;
                break;
            }
        }
        Civil c = civil_from_days(first_day);
        std::int64_t y = c.year;
        int m = c.month;
        if (c.day != 1) ++m;
        while ((m - 1) % months != 0) ++m;
        for (;;) {
            while (m > 12) {
                m -= 12;
                ++y;
            }
            const std::int64_t d = days_from_civil(y, m, 1);
            if (d > last_day) break;
            ticks.push_back({static_cast<double>(d), date_label(d, 2)});
            m += months;
        }
    } else {
        const auto years = static_cast<std::int64_t>(std::max(1.0, nice_number(wanted_step / kDaysPerYear, true)));
        const Civil c = civil_from_days(first_day);
        std::int64_t y = c.year + ((c.month == 1 && c.day == 1) ? 0 : 1);
        y += ((-y) % years + years) % years;
        for (;; y += years) {
            const std::int64_t d = days_from_civil(y, 1, 1);
            if (d > last_day) break;
            ticks.push_back({static_cast<double>(d), date_label(d, 1)});
        }
    }
    return ticks;
}

}  // namespace emadiag::report
