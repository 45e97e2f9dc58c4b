#include "prognostics/utc_time.hpp"

#include "core/emadiag_error.hpp"
#include "emadiag/io/utc_now.hpp"

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>

namespace emadiag::prognostics {
namespace {

/// "YYYY-MM-DDThh:mm:ss": '9' stands for a digit.
constexpr const char* kPattern = "9999-99-99T99:99:99";
constexpr std::size_t kPatternLength = 19;
constexpr int kSecondsPerMinute = 60;
constexpr int kSecondsPerHour = 3600;

bool is_leap(std::int64_t y) { return (y % 4 == 0 && y % 100 != 0) || y % 400 == 0; }

int days_in_month(std::int64_t y, int m) {
    constexpr int kDays[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
    return m == 2 && is_leap(y) ? 29 : kDays[m - 1];
}

/// The inverse: civil_from_days of the same paper.
void civil_from_days(std::int64_t z, std::int64_t& y, int& m, int& d) {
    z += 719468;
    const std::int64_t era = (z >= 0 ? z : z - 146096) / 146097;
    const std::int64_t doe = z - era * 146097;
    const std::int64_t yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
    const std::int64_t doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    const std::int64_t mp = (5 * doy + 2) / 153;
    d = static_cast<int>(doy - (153 * mp + 2) / 5 + 1);
    m = static_cast<int>(mp < 10 ? mp + 3 : mp - 9);
    y = yoe + era * 400 + (m <= 2 ? 1 : 0);
}

int digits(const std::string& s, std::size_t pos, std::size_t n) {
    int v = 0;
    for (std::size_t i = 0; i < n; ++i) v = v * 10 + (s[pos + i] - '0');
    return v;
}

}  // namespace

std::optional<double> parse_utc_days(const std::string& text, std::string& problem) {
    const std::string form = "expected YYYY-MM-DDThh:mm:ss with an optional fraction and 'Z'";
    if (text.size() < kPatternLength) {
        problem = form;
        return std::nullopt;
    }
    for (std::size_t i = 0; i < kPatternLength; ++i) {
        const bool ok = kPattern[i] == '9' ? text[i] >= '0' && text[i] <= '9' : text[i] == kPattern[i];
        if (!ok) {
            problem = form + " (character " + std::to_string(i + 1) + ")";
            return std::nullopt;
        }
    }
    std::size_t pos = kPatternLength;
    double fraction_s = 0;
    if (pos < text.size() && text[pos] == '.') {
        double scale = 0.1;
        const std::size_t first = ++pos;
        while (pos < text.size() && text[pos] >= '0' && text[pos] <= '9') {
            fraction_s += scale * (text[pos] - '0');
            scale *= 0.1;
            ++pos;
        }
        if (pos == first) {
            problem = form + " (a '.' without fraction digits)";
            return std::nullopt;
        }
    }
    if (pos < text.size() && text[pos] == 'Z') ++pos;
    if (pos != text.size()) {
        problem = form + " (unexpected \"" + text.substr(pos) + "\"; time zone offsets are not accepted)";
        return std::nullopt;
    }
    const std::int64_t year = digits(text, 0, 4);
    const int month = digits(text, 5, 2), day = digits(text, 8, 2);
    const int hour = digits(text, 11, 2), minute = digits(text, 14, 2), second = digits(text, 17, 2);
    if (month < 1 || month > 12) {
        problem = "month " + std::to_string(month) + " is not 1 to 12";
        return std::nullopt;
    }
    if (day < 1 || day > days_in_month(year, month)) {
        problem = "day " + std::to_string(day) + " is not in " + text.substr(0, 7);
        return std::nullopt;
    }
    if (hour > 23 || minute > 59 || second > 59) {
        problem = "time " + text.substr(11, 8) + " is not within 00:00:00 to 23:59:59";
        return std::nullopt;
    }
    const double seconds = hour * kSecondsPerHour + minute * kSecondsPerMinute + second + fraction_s;
    return calc::days_since_epoch(year, month, day, seconds);
}

double parse_utc_days_or_throw(const std::string& text, const std::string& what) {
    std::string problem;
    const auto days = parse_utc_days(text, problem);
    if (!days) throw EmadiagError(what + " \"" + text + "\" is not a UTC time: " + problem);
    return *days;
}

std::string format_utc_date(double days_since_epoch) {
    std::int64_t y = 0;
    int m = 0, d = 0;
    civil_from_days(static_cast<std::int64_t>(std::floor(days_since_epoch)), y, m, d);
    char buf[32];
    std::snprintf(buf, sizeof buf, "%04lld-%02d-%02d", static_cast<long long>(y), m, d);
    return buf;
}

std::string format_utc_time(double days_since_epoch) {
    const auto total_s = static_cast<std::int64_t>(std::llround(days_since_epoch * kSecondsPerDay));
    const std::int64_t day = total_s >= 0 ? total_s / 86400 : -((-total_s + 86399) / 86400);
    const std::int64_t s = total_s - day * 86400;
    std::int64_t y = 0;
    int m = 0, d = 0;
    civil_from_days(day, y, m, d);
    char buf[40];
    std::snprintf(buf, sizeof buf, "%04lld-%02d-%02dT%02d:%02d:%02dZ", static_cast<long long>(y), m, d,
                  static_cast<int>(s / kSecondsPerHour), static_cast<int>(s % kSecondsPerHour / kSecondsPerMinute),
                  static_cast<int>(s % kSecondsPerMinute));
    return buf;
}

std::string now_utc_time() { return io::utc_now_iso8601(); }

}  // namespace emadiag::prognostics
