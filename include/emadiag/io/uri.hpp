#pragma once
// URIs in messages (issue 21 item 8): redact_uri_passwords is the one function every message that
// may hold a URI goes through, so a password typed into a connection URI (postgresql://alice:PW@host)
// is never printed, whole or malformed. has_uri_scheme tells a URI from a file path, for the commands
// that work on a SQLite file only. Header-only: maintenance_db, its fleet-server part and src/ use it.
#include <cctype>
#include <cstddef>
#include <string>
#include <string_view>

namespace emadiag::io {

/// Replaces a password with this (the user name and the host stay, to say which URI is meant).
inline constexpr std::string_view kRedactedPassword = "***";

/// True when `text` starts with a URI scheme and "://" (RFC 3986: a letter, then letters, digits,
/// '+', '-' or '.'), such as postgresql://, postgres://, file:// or http://.
[[nodiscard]] inline bool has_uri_scheme(std::string_view text) {
    const std::size_t sep = text.find("://");
    if (sep == std::string_view::npos || sep == 0 || !std::isalpha(static_cast<unsigned char>(text[0]))) return false;
    for (std::size_t i = 1; i < sep; ++i) {
        const unsigned char c = static_cast<unsigned char>(text[i]);
        if (!std::isalnum(c) && c != '+' && c != '-' && c != '.') return false;
    }
    return true;
}

/// `text` (a URI, or a message that quotes one or several) with every password replaced by ***:
///   - in the user information of each scheme://user:PASSWORD@host, up to the last '@' of the URI (a
///     malformed URI such as postgresql://alice:PW@[::1:5432/db included; a password that holds '/',
///     '@' or ':' unencoded is covered whole, at the cost of hiding a little more);
///   - in each password=VALUE (a query parameter or a keyword/value connection string), up to the next
///     '&', blank or quote.
/// A URI ends at a blank, a quote or the end of the text.
[[nodiscard]] inline std::string redact_uri_passwords(std::string_view text) {
    std::string out(text);
    const auto is_end = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '"' || c == '\''; };
    // User information: from the ':' after "scheme://user" to the last '@' of the URI.
    for (std::size_t at = out.find("://"); at != std::string::npos; at = out.find("://", at + 3)) {
        const std::size_t start = at + 3;
        std::size_t end = start;
        while (end < out.size() && !is_end(out[end])) ++end;
        const std::size_t last_at = out.rfind('@', end == 0 ? 0 : end - 1);
        if (last_at == std::string::npos || last_at < start) continue;
        const std::size_t colon = out.find(':', start);
        if (colon == std::string::npos || colon >= last_at) continue;
        out.replace(colon + 1, last_at - colon - 1, kRedactedPassword);
    }
    // password=VALUE, any case.
    std::string lower(out);
    for (auto& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    constexpr std::string_view kKey = "password=";
    for (std::size_t at = lower.find(kKey); at != std::string::npos; at = lower.find(kKey, at + 1)) {
        std::size_t start = at + kKey.size();
        std::size_t end = start;
        if (start < out.size() && (out[start] == '\'' || out[start] == '"')) {  // password='a quoted value'
            const char quote = out[start];
            ++start;
            const std::size_t close = out.find(quote, start);
            end = close == std::string::npos ? out.size() : close;
        } else {
            while (end < out.size() && out[end] != '&' && !is_end(out[end])) ++end;
        }
        out.replace(start, end - start, kRedactedPassword);
        lower.replace(start, end - start, kRedactedPassword);
    }
    return out;
}

}  // namespace emadiag::io
