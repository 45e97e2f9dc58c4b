#pragma once
// Text that people type or files supply (serials, names, certificates, run metadata, file names) on
// its way in and on its way out (issue 21 item 7):
//   - text_field_problem / check_text_field: at the edge, a field must be UTF-8, printable (no C0 or
//     C1 control character, no DEL, no bidirectional override) and at most kMaxTextFieldChars long;
//     the refusal names the field, the offending character's position and its code;
//   - escape_text: at every text output of a stored or file-supplied string, control characters,
//     bidirectional overrides and bytes that are not UTF-8 are rendered visibly (\x1b, \u202e), so a
//     newline cannot print a line of its own ("VERDICT: SERVICEABLE") and an escape sequence never
//     reaches the terminal;
//   - csv_field: the one CSV cell writer of the tool: RFC 4180 quoting, and a cell that a spreadsheet
//     would run as a formula (it starts with = + - @, a tab or a carriage return and is not a plain
//     number) gets a leading single quote (the OWASP CSV-injection rule).
// Header-only: every library uses it.
#include <charconv>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <string_view>

namespace emadiag::io {

/// The longest a typed or file-supplied name may be (serial, operator, technician, certificate),
/// in characters: room for any real one, and an error message that quotes it stays short.
inline constexpr std::size_t kMaxTextFieldChars = 128;

namespace detail {

/// The code point at s[i] and its length in bytes, or nullopt when the bytes there are not UTF-8
/// (overlong forms, surrogates and values above U+10FFFF included).
inline std::optional<std::pair<char32_t, std::size_t>> utf8_at(std::string_view s, std::size_t i) {
    const auto b = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
    const unsigned char c = b(i);
    if (c < 0x80) return std::pair<char32_t, std::size_t>{c, 1};
    std::size_t n = 0;
    char32_t cp = 0;
    if ((c & 0xE0) == 0xC0) n = 2, cp = c & 0x1F;
    else if ((c & 0xF0) == 0xE0) n = 3, cp = c & 0x0F;
    else if ((c & 0xF8) == 0xF0) n = 4, cp = c & 0x07;
    else return std::nullopt;
    if (i + n > s.size()) return std::nullopt;
    for (std::size_t k = 1; k < n; ++k) {
        if ((b(i + k) & 0xC0) != 0x80) return std::nullopt;
        cp = (cp << 6) | (b(i + k) & 0x3F);
    }
    constexpr char32_t kMinOf[5] = {0, 0, 0x80, 0x800, 0x10000};
    if (cp < kMinOf[n] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return std::nullopt;
    return std::pair<char32_t, std::size_t>{cp, n};
}

/// C0 and C1 controls, DEL, and the bidirectional embeddings, overrides and isolates (which reorder
/// what a terminal shows: "Trojan Source"), the line and paragraph separators.
inline bool is_unprintable(char32_t cp) {
    return cp < 0x20 || (cp >= 0x7F && cp <= 0x9F) || (cp >= 0x202A && cp <= 0x202E) || (cp >= 0x2066 && cp <= 0x2069) || cp == 0x2028 ||
           cp == 0x2029;
}

inline std::string code_of(char32_t cp) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "U+%04X", static_cast<unsigned>(cp));
    return buf;
}

}  // namespace detail

/// What is wrong with `value` as the text field `field` ("--serial", "run metadata key operator"), or
/// nullopt when it is printable UTF-8 of at most max_chars characters. Positions count characters from 1.
[[nodiscard]] inline std::optional<std::string> text_field_problem(const std::string& field, std::string_view value,
                                                                   std::size_t max_chars = kMaxTextFieldChars) {
    std::size_t chars = 0;
    for (std::size_t i = 0; i < value.size();) {
        ++chars;
        const auto at = detail::utf8_at(value, i);
        if (!at) {
            char buf[8];
            std::snprintf(buf, sizeof buf, "0x%02X", static_cast<unsigned>(static_cast<unsigned char>(value[i])));
            return field + ": character " + std::to_string(chars) + " (byte " + buf + ") is not UTF-8; use printable UTF-8 text";
        }
        if (detail::is_unprintable(at->first))
            return field + ": character " + std::to_string(chars) + " is the control character " + detail::code_of(at->first) +
                   "; use printable text (no line breaks, tabs, escape sequences or direction overrides)";
        i += at->second;
        if (chars > max_chars) break;
    }
    if (chars > max_chars)
        return field + ": " + std::to_string(value.size()) + " bytes is longer than the limit of " + std::to_string(max_chars) +
               " characters (kMaxTextFieldChars)";
    return std::nullopt;
}

/// Throws Error(problem) when `value` is not a valid text field (see text_field_problem).
template <class Error>
void check_text_field(const std::string& field, std::string_view value, std::size_t max_chars = kMaxTextFieldChars) {
    if (auto problem = text_field_problem(field, value, max_chars)) throw Error(*problem);
}

/// `text` with every control character, bidirectional override and non-UTF-8 byte rendered visibly:
/// \x1b for a byte below 0x80 or not UTF-8, \u202e for a code point; a backslash stays as it is.
/// With keep_newlines, '\n' stays a line break (for messages made of several lines).
[[nodiscard]] inline std::string escape_text(std::string_view text, bool keep_newlines = false) {
    std::string out;
    out.reserve(text.size());
    char buf[16];
    for (std::size_t i = 0; i < text.size();) {
        const auto at = detail::utf8_at(text, i);
        if (!at) {
            std::snprintf(buf, sizeof buf, "\\x%02x", static_cast<unsigned>(static_cast<unsigned char>(text[i])));
            out += buf;
            ++i;
            continue;
        }
        const char32_t cp = at->first;
        if (detail::is_unprintable(cp) && !(keep_newlines && cp == U'\n')) {
            if (cp < 0x80) std::snprintf(buf, sizeof buf, "\\x%02x", static_cast<unsigned>(cp));
            else std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(cp));
            out += buf;
        } else {
            out.append(text.substr(i, at->second));
        }
        i += at->second;
    }
    return out;
}

/// A plain number ("-0.5", "+3", "1e-9") that a spreadsheet reads as a number, not a formula.
[[nodiscard]] inline bool is_plain_number(std::string_view s) {
    if (s.empty()) return false;
    const char* first = s.data();
    const char* last = s.data() + s.size();
    if (*first == '+' || *first == '-') ++first;
    if (first == last || !((*first >= '0' && *first <= '9') || *first == '.')) return false;
    double v = 0;
    const auto [ptr, ec] = std::from_chars(first, last, v);
    return ec == std::errc() && ptr == last;
}

/// One CSV cell: a cell that starts with = + - @, a tab or a carriage return and is not a plain number
/// gets a leading ' (OWASP CSV injection: a spreadsheet never runs it as a formula); control
/// characters, line breaks included, are rendered visibly (escape_text: one record is one line, and a
/// CSV on a terminal prints no forged line and sends no escape sequence); then quoted when it holds a
/// comma or a quote (RFC 4180). The exact text of a multi-line field is in the JSON export.
[[nodiscard]] inline std::string csv_field(std::string_view s) {
    std::string cell;
    if (!s.empty() && (s[0] == '=' || s[0] == '+' || s[0] == '-' || s[0] == '@' || s[0] == '\t' || s[0] == '\r') && !is_plain_number(s))
        cell.push_back('\'');
    cell += escape_text(s);
    if (cell.find_first_of(",\"") == std::string::npos) return cell;
    std::string out = "\"";
    for (char c : cell) out += c == '"' ? std::string("\"\"") : std::string(1, c);
    return out + "\"";
}

}  // namespace emadiag::io
