#include "core/run.hpp"

#include <cstdio>

namespace emadiag {

std::string format_exact(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

void Run::set_required_meta() {
    set_meta("k_t_Nm_per_A", format_exact(constants.k_t_nm_per_a));
    set_meta("J_kgm2", format_exact(constants.j_kgm2));
    set_meta("tau", format_exact(constants.tau));
    set_meta("sample_period_s", format_exact(constants.sample_period_s));
    set_meta("case", sim::to_string(load_case));
    set_meta("sequence", sim::to_string(sequence));
}

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
