#pragma once
// One strict parser for every numeric command-line option (issue 21 item 14). CLI11 converts
// integers with strtoull/strtoll base 0, so "-1" became 2^64 - 1 for a seed, 2^64 was clamped to
// 2^64 - 1, "010" was 8 and "0x10" 16; and it takes "nan" for a double. Here the text must be the
// whole number, in decimal: not empty, no sign on an unsigned option, no leading '+' or spaces,
// nothing out of the type's range (no wrap, no clamp), finite for a real. `check_every_number`
// puts that check on every integer and real option of every command (main.cpp calls it once), and
// `in_range` adds an option's own bounds, named in the message.
#include <CLI/CLI.hpp>

#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>

namespace emadiag::cli {

/// Longest option text quoted in a message (the rest is elided, so a huge argument gives a short error).
inline constexpr std::size_t kMaxQuotedOptionChars = 40;

/// `text` quoted for a message: at most kMaxQuotedOptionChars, control bytes (NUL too) as \xNN.
inline std::string quote_option_text(const std::string& text) {
    std::string out = "'";
    for (std::size_t i = 0; i < text.size() && i < kMaxQuotedOptionChars; ++i) {
        const auto c = static_cast<unsigned char>(text[i]);
        if (c < 0x20 || c == 0x7f) {
            static const char* hex = "0123456789abcdef";
            out += "\\x";
            out += hex[c >> 4];
            out += hex[c & 15];
        } else {
            out += static_cast<char>(c);
        }
    }
    if (text.size() > kMaxQuotedOptionChars) out += "...' (" + std::to_string(text.size()) + " characters)";
    else out += "'";
    return out;
}

template <class T>
std::string number_text(T v) {
    if constexpr (std::is_floating_point_v<T>) {
        std::ostringstream os;
        os.precision(std::numeric_limits<T>::max_digits10);
        os << v;
        return os.str();
    } else {
        return std::to_string(v);
    }
}

/// Parses the whole of `text` as a decimal T into `value`; returns the problem, or nullopt.
template <class T>
std::optional<std::string> number_problem(const std::string& text, T& value) {
    static_assert(std::is_arithmetic_v<T> && !std::is_same_v<T, bool>);
    const char* kind = std::is_floating_point_v<T> ? "a finite decimal number"
                       : std::is_unsigned_v<T>     ? "a whole number >= 0 (decimal digits, no sign)"
                                                   : "a whole number (decimal digits, '-' for a negative)";
    const auto refuse = [&](const std::string& why) {
        return quote_option_text(text) + " is not " + kind + ": " + why;
    };
    if (text.empty()) return refuse("it is empty");
    if (text.front() == '+') return refuse("no '+' sign");
    if (std::is_unsigned_v<T> && text.front() == '-') return refuse("it is negative");
    const char* first = text.data();
    const char* last = text.data() + text.size();
    std::from_chars_result r{};
    if constexpr (std::is_floating_point_v<T>) {
        r = std::from_chars(first, last, value, std::chars_format::general);
    } else {
        r = std::from_chars(first, last, value, 10);
    }
    if (r.ec == std::errc::result_out_of_range) {
        return refuse("outside the range of the option's type [" + number_text(std::numeric_limits<T>::lowest()) + ", " +
                      number_text(std::numeric_limits<T>::max()) + "]");
    }
    if (r.ec != std::errc() || r.ptr != last) return refuse("unexpected character at position " + std::to_string(r.ptr - first + 1));
    if constexpr (std::is_floating_point_v<T>) {
        if (!std::isfinite(value)) return refuse("NaN and infinity are not accepted");
    }
    return std::nullopt;
}

/// Validator: the option's text is a T (number_problem) in [lo, hi]; `range_name` names where the
/// bounds come from (e.g. "kMaxTimesteps") and is printed with them.
template <class T>
CLI::Validator in_range(T lo, T hi, const std::string& range_name = "") {
    const std::string range = "[" + number_text(lo) + ", " + number_text(hi) + "]" + (range_name.empty() ? "" : " (" + range_name + ")");
    return CLI::Validator(
        [lo, hi, range](std::string& text) -> std::string {
            T v{};
            if (const auto problem = number_problem(text, v)) return *problem;
            if (v < lo || v > hi) return number_text(v) + " is outside " + range;
            return {};
        },
        "in " + range, "in_range");
}

/// The strict check of number_problem, for an option whose C++ type CLI11 names `type_name`
/// (INT, UINT or FLOAT); an empty Validator otherwise.
inline std::optional<CLI::Validator> strict_number_check(const std::string& type_name) {
    const auto make = [](auto zero) {
        using T = decltype(zero);
        return CLI::Validator(
            [](std::string& text) -> std::string {
                T v{};
                const auto problem = number_problem(text, v);
                return problem ? *problem : std::string();
            },
            "", "strict_number");
    };
    if (type_name == "INT") return make(std::int64_t{0});
    if (type_name == "UINT") return make(std::uint64_t{0});
    if (type_name == "FLOAT") return make(double{0});
    return std::nullopt;
}

/// Adds strict_number_check to every integer and real option of `app` and of its subcommands,
/// so an option declared anywhere in src/cli/ gets it without its command asking.
inline void check_every_number(CLI::App& app) {
    for (CLI::Option* opt : app.get_options()) {
        if (opt->get_type_size() <= 0) continue;  // flags
        if (auto check = strict_number_check(opt->get_type_name())) opt->check(*check);
    }
    for (CLI::App* sub : app.get_subcommands({})) check_every_number(*sub);
}

}  // namespace emadiag::cli
