// The profile as text for `emadiag actuator show`: every leaf of the file with its unit, read from
// the field name's suffix (the schema puts the unit in the name, docs/actuator-profile.md).
#include "actuator/actuator_profile.hpp"

#include <array>
#include <utility>

namespace emadiag::actuator {

using nlohmann::json;

namespace {

/// Field-name suffixes and their units, longest first where one ends another (_nm_per_s before _per_s).
constexpr std::array<std::pair<std::string_view, std::string_view>, 29> kSuffixUnits{{
    {"_nm_s_per_rad", "N m s/rad"}, {"_a_s_per_rad", "A s/rad"}, {"_a_s_per_m", "A s/m"}, {"_nm_per_a", "N m/A"},
    {"_a_per_nm", "A/(N m)"},       {"_a_per_n", "A/N"},         {"_nm_per_s", "N m/s"},   {"_n_per_s", "N/s"},
    {"_a_per_s", "A/s"},            {"_per_rad", "1/rad"},       {"_per_s", "1/s"},        {"_rad_s", "rad/s"},
    {"_deg_s", "deg/s"},            {"_m_s", "m/s"},             {"_kgm2", "kg m^2"},      {"_ohm", "ohm"},
    {"_hz", "Hz"},                  {"_pa", "Pa"},               {"_m2", "m^2"},           {"_nm", "N m"},
    {"_deg", "deg"},                {"_rad", "rad"},             {"_v", "V"},              {"_h", "H"},
    {"_a", "A"},                    {"_s", "s"},                 {"_m", "m"},              {"_n", "N"},
    {"_utc", "UTC"},
}};

/// Numeric fields without a unit (ratios, efficiencies, counts, the aircraft model's matrices in its
/// state's units) or whose unit is given beside them (a sensor's "unit", a prior's parameter).
constexpr std::array<std::string_view, 12> kDimensionless{
    "gear_ratio", "efficiency_opposing", "efficiency_aiding", "samples", "cycles", "state_matrix",
    "input_matrix", "nominal", "min", "max", "resolution", "noise_sd"};

std::string leaf_text(const json& v) {
    if (v.is_null()) return "unknown";
    if (v.is_string()) return v.get<std::string>();
    return v.dump();
}

bool numeric(const json& v) {
    if (v.is_number()) return true;
    if (!v.is_array() || v.empty()) return false;
    for (const json& e : v) {
        if (!numeric(e)) return false;
    }
    return true;
}

/// The unit shown after a field's value, with its context: a sensor's resolution and noise are in
/// its "unit"; a prior's values in its parameter's (FDJ_Nm, FSJ_Nm: N m).
std::string shown_unit(const json& parent, const std::string& key) {
    if ((key == "resolution" || key == "noise_sd") && parent.contains("unit") && parent.at("unit").is_string()) {
        return parent.at("unit").get<std::string>();
    }
    if ((key == "nominal" || key == "min" || key == "max") && parent.contains("parameter") && parent.at("parameter").is_string()) {
        return parent.at("parameter").get<std::string>().ends_with("_Nm") ? "N m" : "";
    }
    return unit_of_field(key).value_or("");
}

void walk(const json& node, const std::string& path, std::vector<std::string>& out) {
    for (auto it = node.begin(); it != node.end(); ++it) {
        const std::string key = node.is_object() ? it.key() : std::to_string(&*it - &node[0]);
        const std::string at = path + "/" + key;
        const json& v = *it;
        if (v.is_object() || (v.is_array() && !v.empty() && !numeric(v) && (v[0].is_object() || v[0].is_array()))) {
            walk(v, at, out);
            continue;
        }
        std::string line = at + " = ";
        if (v.is_array() && !numeric(v)) {
            std::string items;
            for (const json& e : v) items += (items.empty() ? "" : ", ") + leaf_text(e);
            line += "[" + items + "]";
        } else {
            line += leaf_text(v);
        }
        if (!v.is_null() && numeric(v) && node.is_object()) {
            const std::string unit = shown_unit(node, key);
            if (!unit.empty()) line += " " + unit;
        }
        out.push_back(line);
    }
}

void nulls(const json& node, const std::string& path, std::vector<std::string>& out) {
    for (auto it = node.begin(); it != node.end(); ++it) {
        const std::string at = path + "/" + (node.is_object() ? it.key() : std::to_string(&*it - &node[0]));
        if (it->is_null()) out.push_back(at);
        else if (it->is_structured()) nulls(*it, at, out);
    }
}

}  // namespace

std::optional<std::string> unit_of_field(std::string_view field) {
    for (const std::string_view d : kDimensionless) {
        if (field == d) return std::string();
    }
    for (const auto& [suffix, unit] : kSuffixUnits) {
        if (field.ends_with(suffix)) return std::string(unit);
    }
    return std::nullopt;
}

std::vector<std::string> describe_profile(const ActuatorProfile& profile) {
    std::vector<std::string> out;
    out.push_back("file = " + profile.path);
    out.push_back("sha256 = " + profile.sha256);
    walk(profile.document, "", out);
    return out;
}

std::vector<std::string> unknown_fields(const ActuatorProfile& profile) {
    std::vector<std::string> out;
    nulls(profile.document, "", out);
    return out;
}

}  // namespace emadiag::actuator
