#include "emadiag/io/bounded_json.hpp"
#include "actuator/profile_reader.hpp"

#include "actuator/actuator_error.hpp"
#include "actuator/actuator_profile.hpp"

#include <cmath>

namespace emadiag::actuator::detail {

using nlohmann::json;

namespace {

std::string child(const std::string& path, const char* key) { return path + "/" + key; }

bool printable(const std::string& s) {
    for (const char c : s) {
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) return false;
    }
    return true;
}

}  // namespace

void ProfileReader::problem(const std::string& path, const std::string& message) {
    problems_.push_back(source_ + ": " + (path.empty() ? "/" : path) + ": " + message);
}

void ProfileReader::throw_if_any() const {
    if (problems_.empty()) return;
    std::string text = "actuator profile " + source_ + ": " + std::to_string(problems_.size()) + " problem" +
                       (problems_.size() == 1 ? "" : "s");
    for (const std::string& p : problems_) text += "\n  " + p;
    throw ActuatorError(text);
}

void ProfileReader::keys(const json& obj, const std::string& path, std::initializer_list<const char*> allowed) {
    io::for_each_unknown_key(obj, allowed, [&](const std::string& key, const std::string& known) {
        problem(path + "/" + key, "unknown key (known here: " + known + ")");
    });
    for (const char* a : allowed) {
        if (!obj.contains(a)) problem(child(path, a), "missing (every key is required: write null for a value that is unknown)");
    }
}

std::string ProfileReader::bound_text(Bound bound) {
    switch (bound) {
        case Bound::finite: return "a finite number";
        case Bound::positive: return "> 0";
        case Bound::non_negative: return ">= 0";
        case Bound::efficiency: return "in (0, 1]";
    }
    return "";
}

const json* ProfileReader::object(const json& obj, const std::string& path, const char* key, Null null) {
    const auto it = obj.find(key);
    if (it == obj.end()) return nullptr;  // keys() reports it
    if (it->is_null() && null == Null::allowed) return nullptr;
    if (!it->is_object()) {
        problem(child(path, key), std::string("must be an object") + (null == Null::allowed ? " or null" : "") + ", not " + it->dump());
        return nullptr;
    }
    return &*it;
}

std::optional<double> ProfileReader::number(const json& obj, const std::string& path, const char* key, Bound bound, Null null) {
    const auto it = obj.find(key);
    if (it == obj.end()) return std::nullopt;
    if (it->is_null()) {
        if (null == Null::refused) problem(child(path, key), "must be known (" + bound_text(bound) + "), not null");
        return std::nullopt;
    }
    if (!it->is_number() || !std::isfinite(it->get<double>())) {
        problem(child(path, key), "must be a finite number" + std::string(null == Null::allowed ? " or null (unknown)" : "") + ", not " + it->dump());
        return std::nullopt;
    }
    const double v = it->get<double>();
    const bool ok = bound == Bound::finite || (bound == Bound::positive && v > 0) || (bound == Bound::non_negative && v >= 0) ||
                    (bound == Bound::efficiency && v > 0 && v <= 1);
    if (!ok) {
        problem(child(path, key), "must be " + bound_text(bound) + ", not " + it->dump());
        return std::nullopt;
    }
    return v;
}

std::optional<std::size_t> ProfileReader::count(const json& obj, const std::string& path, const char* key, std::size_t min) {
    const auto it = obj.find(key);
    if (it == obj.end()) return std::nullopt;
    if (!it->is_number_unsigned() || it->get<std::size_t>() < min) {
        problem(child(path, key), "must be a whole number >= " + std::to_string(min) + ", not " + it->dump());
        return std::nullopt;
    }
    return it->get<std::size_t>();
}

std::optional<std::string> ProfileReader::text(const json& obj, const std::string& path, const char* key, std::size_t max_chars, Null null) {
    const auto it = obj.find(key);
    if (it == obj.end()) return std::nullopt;
    if (it->is_null() && null == Null::allowed) return std::nullopt;
    if (!it->is_string()) {
        problem(child(path, key), std::string("must be a string") + (null == Null::allowed ? " or null" : "") + ", not " + it->dump());
        return std::nullopt;
    }
    const std::string s = it->get<std::string>();
    if (s.empty() || s.size() > max_chars || !printable(s)) {
        problem(child(path, key), "must be 1 to " + std::to_string(max_chars) + " printable characters, not " + it->dump().substr(0, 80) +
                                      (s.size() > 78 ? "... (" + std::to_string(s.size()) + " characters)" : ""));
        return std::nullopt;
    }
    return s;
}

std::optional<std::size_t> ProfileReader::choice(const json& obj, const std::string& path, const char* key,
                                                 const std::vector<const char*>& names, Null null) {
    const auto it = obj.find(key);
    if (it == obj.end()) return std::nullopt;
    if (it->is_null() && null == Null::allowed) return std::nullopt;
    if (it->is_string()) {
        for (std::size_t i = 0; i < names.size(); ++i) {
            if (it->get<std::string>() == names[i]) return i;
        }
    }
    std::string list;
    for (const char* n : names) list += (list.empty() ? "\"" : ", \"") + std::string(n) + "\"";
    if (null == Null::allowed) list += ", null (unknown)";
    problem(child(path, key), "must be one of " + list + ", not " + it->dump());
    return std::nullopt;
}

std::vector<std::pair<std::string, const json*>> ProfileReader::array(const json& obj, const std::string& path, const char* key, Null null) {
    std::vector<std::pair<std::string, const json*>> out;
    const auto it = obj.find(key);
    if (it == obj.end() || (it->is_null() && null == Null::allowed)) return out;
    const std::string at = child(path, key);
    if (!it->is_array()) {
        problem(at, "must be an array, not " + it->dump().substr(0, 80));
        return out;
    }
    if (it->size() > kMaxProfileEntries) {
        problem(at, std::to_string(it->size()) + " entries exceed the limit kMaxProfileEntries = " + std::to_string(kMaxProfileEntries));
    }
    for (std::size_t i = 0; i < it->size() && i < kMaxProfileEntries; ++i) out.emplace_back(at + "/" + std::to_string(i), &(*it)[i]);
    return out;
}

std::optional<std::vector<double>> ProfileReader::numbers(const json& value, const std::string& path, std::size_t max_count) {
    bool ok = value.is_array() && !value.empty() && value.size() <= max_count;
    for (std::size_t i = 0; ok && i < value.size(); ++i) ok = value[i].is_number() && std::isfinite(value[i].get<double>());
    if (!ok) {
        problem(path, "must be an array of 1 to " + std::to_string(max_count) + " finite numbers, not " + value.dump().substr(0, 80));
        return std::nullopt;
    }
    return value.get<std::vector<double>>();
}

std::optional<std::pair<double, double>> ProfileReader::interval(const json& obj, const std::string& path, const char* key, Null null) {
    const auto it = obj.find(key);
    if (it == obj.end()) return std::nullopt;
    if (it->is_null()) {
        if (null == Null::refused) problem(child(path, key), "must be known: [low, high], not null");
        return std::nullopt;
    }
    const auto v = numbers(*it, child(path, key), 2);
    if (!v) return std::nullopt;
    if (v->size() != 2 || (*v)[0] >= (*v)[1]) {
        problem(child(path, key), "must be [low, high] with low < high, not " + it->dump());
        return std::nullopt;
    }
    return std::make_pair((*v)[0], (*v)[1]);
}

}  // namespace emadiag::actuator::detail
