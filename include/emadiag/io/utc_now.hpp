#pragma once
// The system clock now as "YYYY-MM-DDThh:mm:ssZ" (UTC, to the second): when a session started, a
// sync ran or a finding was stored. One definition for every library (header-only, like the rest of
// include/emadiag/io/).
#include <ctime>
#include <string>

namespace emadiag::io {

[[nodiscard]] inline std::string utc_now_iso8601() {
    const std::time_t t = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

}  // namespace emadiag::io
