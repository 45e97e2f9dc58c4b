#include "core/run.hpp"

namespace emadiag {

std::optional<std::string> Run::meta_value(const std::string& key) const {
    for (const auto& [k, v] : meta) {
        if (k == key) return v;
    }
    return std::nullopt;
}

void Run::set_meta(const std::string& key, const std::string& value) {
    for (auto& [k, v] : meta) {
        if (k == key) {
            v = value;
            return;
        }
    }
    meta.emplace_back(key, value);
}

std::vector<std::pair<std::string, std::string>> Run::analysis_meta() const {
    std::vector<std::pair<std::string, std::string>> out;
    for (const auto& kv : meta) {
        if (kv.first.rfind("true_", 0) == 0 || kv.first.rfind("effect_", 0) == 0) continue;
        out.push_back(kv);
    }
    return out;
}

}  // namespace emadiag
