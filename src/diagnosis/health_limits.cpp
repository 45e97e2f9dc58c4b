#include "diagnosis/health_limits.hpp"

#include "core/emadiag_error.hpp"
#include "estimation/dataset.hpp"
#include "emadiag/io/bounded_json.hpp"
#include "estimation/health_estimate.hpp"
#include "emadiag/sim/ema_params.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>

namespace emadiag {
namespace {

/// An efficiency is a fraction of the power that goes through: a limit on one lies in (0, 1].
constexpr double kMaxEfficiency = 1.0;

/// Friction may not rise above its limit; efficiency may not fall below it.
LimitKind natural_kind(const std::string& parameter) {
    const auto p = parse_health_parameter(parameter);
    return p && (*p == HealthParameter::Fdj || *p == HealthParameter::Fsj) ? LimitKind::Max : LimitKind::Min;
}

}  // namespace

const char* to_string(LimitKind k) { return k == LimitKind::Max ? "max" : "min"; }

HealthLimits HealthLimits::datasheet_envelope() {
    HealthLimits h;
    h.source = "ema-reference.md section 8 envelope (nominal +/-20 %)";
    for (const char* p : kHealthParameterNames) {
        const HealthRange r = health_range(p);
        const LimitKind k = natural_kind(p);
        h.limits.push_back({p, k, k == LimitKind::Max ? r.hi : r.lo});
    }
    return h;
}

HealthLimits HealthLimits::from_json(const nlohmann::json& j, const std::string& where) {
    HealthLimits h = datasheet_envelope();
    h.source = where;
    std::vector<std::string> problems;
    if (!j.is_object()) throw EmadiagError(where + ": limits must be a JSON object such as {\"FDJ_Nm\": {\"max\": 0.09}}");
    for (const auto& item : j.items()) {
        const std::string& key = item.key();  // not a structured binding: clang captures none in a lambda
        const nlohmann::json& v = item.value();
        auto it = std::find_if(h.limits.begin(), h.limits.end(), [&](const ParameterLimit& l) { return l.parameter == key; });
        if (it == h.limits.end()) {
            problems.push_back("unknown parameter \"" + key + "\" (expected FDJ_Nm, FSJ_Nm, eta_O or eta_A)");
            continue;
        }
        const std::string want = to_string(natural_kind(key));
        const std::string other = natural_kind(key) == LimitKind::Max ? "min" : "max";
        if (!v.is_object() || v.size() != 1 || !v.contains(want)) {
            problems.push_back(key + ": expected {\"" + want + "\": value}" +
                               (v.is_object() && v.contains(other) ? " (a " + other + " limit makes no sense for it)" : "") +
                               ", got " + v.dump());
            continue;
        }
        const auto& x = v.at(want);
        if (!x.is_number() || !std::isfinite(x.get<double>()) || x.get<double>() <= 0) {
            problems.push_back(key + "." + want + ": " + x.dump() + " is not a finite positive number");
            continue;
        }
        // A friction torque the motor cannot overcome (T_max, ema-reference.md section 1), or an
        // efficiency above 1, is no limit of this actuator.
        const bool friction = natural_kind(key) == LimitKind::Max;
        const double most = friction ? sim::EmaParams::datasheet().t_max_nm : kMaxEfficiency;
        if (x.get<double>() > most) {
            problems.push_back(key + "." + want + ": " + x.dump() + (friction ? " N m exceeds the motor torque saturation T_max = "
                                                                              : " exceeds the largest possible efficiency, ") +
                               nlohmann::json(most).dump() + (friction ? " N m (a friction torque lies in (0, T_max])" : " (an efficiency lies in (0, 1])"));
            continue;
        }
        it->limit = x.get<double>();
    }
    if (!problems.empty()) {
        std::string msg = where + ": " + std::to_string(problems.size()) + " problem(s) in the limits:";
        for (const auto& p : problems) msg += "\n  " + p;
        throw EmadiagError(msg);
    }
    return h;
}

HealthLimits HealthLimits::load(const std::string& path) {
    std::string error;
    const auto j = io::read_bounded_json_file(path, error);
    if (!j) throw EmadiagError(path + (error == "cannot open" ? ": cannot open the limits file" : ": " + error));
    return from_json(*j, path);
}

const ParameterLimit* HealthLimits::find(const std::string& parameter) const {
    for (const auto& l : limits)
        if (l.parameter == parameter) return &l;
    return nullptr;
}

nlohmann::json HealthLimits::to_json() const {
    nlohmann::json j = nlohmann::json::object();
    for (const auto& l : limits) j[l.parameter] = {{to_string(l.kind), l.limit}};
    return j;
}

}  // namespace emadiag
