#pragma once
// The shortest text that reads back as the same double (std::to_chars): numbers in messages and
// signal descriptions.
#include <charconv>
#include <string>

namespace emadiag::measured {

inline std::string number_text(double v) {
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, r.ptr);
}

}  // namespace emadiag::measured
