#pragma once
// Reading JSON input files with bounded memory and stack (issue 12 part 2; docs/limits.md). Every
// JSON loader (simulator parameters, network models, limits, augmented models, the dataset header)
// parses through parse_bounded_json: the text is refused before parsing when it is larger than
// kMaxJsonBytes or nests arrays/objects deeper than kMaxJsonDepth, so no input makes a later
// recursive walk (dump, comparison, copy) recurse without limit.
#include <nlohmann/json.hpp>

#include <cstddef>
#include <fstream>
#include <initializer_list>
#include <optional>
#include <string>
#include <set>
#include <string_view>
#include <vector>

namespace emadiag::io {

/// Deepest nesting of arrays and objects accepted (the project's files nest at most 4 deep).
inline constexpr int kMaxJsonDepth = 64;
/// Largest JSON file accepted (the shipped network models are about 0.55 MB).
inline constexpr std::size_t kMaxJsonBytes = std::size_t{16} << 20;

/// Parses `text`; on failure returns nullopt with the reason (the limit by name, the parser's
/// message with its byte position, or a key repeated in one object with the object's path) in `error`.
[[nodiscard]] inline std::optional<nlohmann::json> parse_bounded_json(std::string_view text, std::string& error) {
    if (text.size() > kMaxJsonBytes) {
        error = "JSON text of " + std::to_string(text.size()) + " bytes exceeds the limit kMaxJsonBytes = " +
                std::to_string(kMaxJsonBytes);
        return std::nullopt;
    }
    int depth = 0;
    bool in_string = false, escaped = false;
    for (std::size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (in_string) {
            if (escaped) escaped = false;
            else if (c == '\\') escaped = true;
            else if (c == '"') in_string = false;
        } else if (c == '"') {
            in_string = true;
        } else if (c == '[' || c == '{') {
            if (++depth > kMaxJsonDepth) {
                error = "JSON nests deeper than the limit kMaxJsonDepth = " + std::to_string(kMaxJsonDepth) + " at byte " +
                        std::to_string(i);
                return std::nullopt;
            }
        } else if ((c == ']' || c == '}') && depth > 0) {
            --depth;
        }
    }
    // A repeated key in an object is refused (issue 21): nlohmann keeps the last one silently, so
    // {"eta_O": {"min": 0.8}, "eta_O": {"min": 0.1}} would read as a limit nobody sees in the file.
    struct Level {
        bool object = false;
        std::string path, last_key;
        std::set<std::string> keys;  // a set: a 16 MB object of distinct keys stays O(n log n)
    };
    std::vector<Level> levels;
    std::string duplicate;
    const nlohmann::json::parser_callback_t check_keys = [&](int, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
        using E = nlohmann::json::parse_event_t;
        if (event == E::object_start || event == E::array_start) {
            Level l;
            l.object = event == E::object_start;
            if (!levels.empty()) l.path = levels.back().path + "/" + (levels.back().object ? levels.back().last_key : std::string("*"));
            levels.push_back(std::move(l));
        } else if (event == E::object_end || event == E::array_end) {
            if (!levels.empty()) levels.pop_back();
        } else if (event == E::key && !levels.empty() && parsed.is_string()) {
            Level& l = levels.back();
            l.last_key = parsed.get<std::string>();
            if (!l.keys.insert(l.last_key).second && duplicate.empty()) {
                duplicate = "duplicate key \"" + l.last_key + "\" in the object at " + (l.path.empty() ? "/" : l.path) +
                            ": a JSON object may not repeat a key (the last one would silently win)";
            }
        }
        return true;
    };
    try {
        nlohmann::json j = nlohmann::json::parse(text.begin(), text.end(), check_keys);
        if (!duplicate.empty()) {
            error = duplicate;
            return std::nullopt;
        }
        return j;
    } catch (const nlohmann::json::exception& e) {
        // parse_error, and out_of_range 406 for a number beyond double (1e999): both bad input.
        error = std::string("not valid JSON: ") + e.what();
        return std::nullopt;
    }
}

/// Reads a whole file of at most kMaxJsonBytes into `text` (the bytes a loader parses and hashes);
/// on failure returns false with the reason in `error` ("cannot open", the size limit, "read error").
[[nodiscard]] inline bool read_bounded_text_file(const std::string& path, std::string& text, std::string& error) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        error = "cannot open";
        return false;
    }
    text.clear();
    char buf[65536];
    while (in.read(buf, sizeof buf) || in.gcount() > 0) {
        text.append(buf, static_cast<std::size_t>(in.gcount()));
        if (text.size() > kMaxJsonBytes) {
            error = "file exceeds the limit kMaxJsonBytes = " + std::to_string(kMaxJsonBytes) + " bytes";
            return false;
        }
    }
    if (in.bad()) {
        error = "read error";
        return false;
    }
    return true;
}

/// Reads a whole JSON file (at most kMaxJsonBytes) and parses it; on failure returns nullopt with
/// the reason in `error` ("cannot open", the size limit, the depth limit, the parse error).
[[nodiscard]] inline std::optional<nlohmann::json> read_bounded_json_file(const std::string& path, std::string& error) {
    std::string text;
    if (!read_bounded_text_file(path, text, error)) return std::nullopt;
    return parse_bounded_json(text, error);
}

/// Calls problem(key, known) for every key of the object `obj` outside `allowed`, where `known` is
/// the allowed keys as "a, b, c" (a misspelt key in a schema file would otherwise be ignored).
template <class Problem>
void for_each_unknown_key(const nlohmann::json& obj, std::initializer_list<const char*> allowed, Problem&& problem) {
    for (auto it = obj.begin(); it != obj.end(); ++it) {
        bool known = false;
        for (const char* a : allowed) known = known || it.key() == a;
        if (!known) {
            std::string list;
            for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
            problem(it.key(), list);
        }
    }
}

}  // namespace emadiag::io
