#include "emadiag/sim/ema_params.hpp"

#include "emadiag/io/bounded_json.hpp"
#include "emadiag/sim/sim_error.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

namespace emadiag::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct FieldSpec {
    const char* name;
    double EmaParams::*member;
    double min;
    bool min_inclusive;
    double max;
    bool max_inclusive;
    const char* unit;
};

// Allowed ranges. Strict bounds where zero or negative values are unphysical
// (R > 0, 0 < eta_O <= 1, eta_A < 1, see paper section 2.4).
const FieldSpec kFields[] = {
    {"v_dc_v", &EmaParams::v_dc_v, 0.0, false, kInf, false, "V"},
    {"r_ohm", &EmaParams::r_ohm, 0.0, false, kInf, false, "ohm"},
    {"l_h", &EmaParams::l_h, 0.0, false, kInf, false, "H"},
    {"k_t_nm_per_a", &EmaParams::k_t_nm_per_a, 0.0, false, kInf, false, "N m/A"},
    {"i_max_a", &EmaParams::i_max_a, 0.0, false, kInf, false, "A"},
    {"t_max_nm", &EmaParams::t_max_nm, 0.0, false, kInf, false, "N m"},
    {"w_max_rad_s", &EmaParams::w_max_rad_s, 0.0, false, kInf, false, "rad/s"},
    {"j_kgm2", &EmaParams::j_kgm2, 0.0, false, kInf, false, "kg m^2"},
    {"tau", &EmaParams::tau, 1.0, true, kInf, false, "-"},
    {"k_theta_per_s", &EmaParams::k_theta_per_s, 0.0, false, kInf, false, "1/s"},
    {"k_w_a_s_per_rad", &EmaParams::k_w_a_s_per_rad, 0.0, false, kInf, false, "A s/rad"},
    {"stop_deg", &EmaParams::stop_deg, 0.0, false, 90.0, true, "deg"},
    {"fdj_nm", &EmaParams::fdj_nm, 0.0, true, kInf, false, "N m"},
    {"fsj_nm", &EmaParams::fsj_nm, 0.0, true, kInf, false, "N m"},
    {"eta_o", &EmaParams::eta_o, 0.0, false, 1.0, true, "-"},
    {"eta_a", &EmaParams::eta_a, -kInf, false, 1.0, false, "-"},
    {"dt_s", &EmaParams::dt_s, 0.0, false, 1e-4, true, "s"},
};

struct EffectSpec {
    const char* name;
    double Effects::*member;
    double min;
    double max;
    const char* unit;
};

const EffectSpec kEffects[] = {
    {"viscous", &Effects::viscous_nm_s_rad, 0.0, 1.0, "N m s/rad"},
    {"stribeck_amplitude", &Effects::stribeck_amplitude_nm, 0.0, 10.0, "N m"},
    {"stribeck_speed", &Effects::stribeck_speed_rad_s, 1e-6, 1e4, "rad/s"},
    {"backlash", &Effects::backlash_rad, 0.0, 100.0, "rad"},
    {"spall_amplitude", &Effects::spall_amplitude_nm, 0.0, 10.0, "N m"},
    {"spall_center", &Effects::spall_center_deg, -90.0, 90.0, "deg"},
    {"spall_width", &Effects::spall_width_deg, 1e-6, 90.0, "deg"},
    {"ripple_amplitude", &Effects::ripple_amplitude_nm, 0.0, 10.0, "N m"},
    {"ripple_periods", &Effects::ripple_periods_per_rev, 0.0, 1000.0, "1/rev"},
    {"current_gain_error", &Effects::current_gain_error, -0.5, 0.5, "-"},
    {"hinge_offset", &Effects::hinge_offset_nm, -5000.0, 5000.0, "N m"},
    {"true_inertia", &Effects::true_inertia_kgm2, 0.0, 1.0, "kg m^2"},
};

std::string fmt(double v) {
    std::ostringstream os;
    os.precision(10);
    os << v;
    return os.str();
}

std::string range_text(const FieldSpec& f) {
    std::string s = f.min_inclusive ? "[" : "(";
    s += std::isinf(f.min) ? "-inf" : fmt(f.min);
    s += ", ";
    s += std::isinf(f.max) ? "inf" : fmt(f.max);
    s += f.max_inclusive ? "]" : ")";
    return s;
}

const EffectSpec* find_effect(const std::string& name) {
    for (const auto& e : kEffects) {
        if (name == e.name) return &e;
    }
    return nullptr;
}

}  // namespace

double eta_a_from_eta_o(double eta_o, double tau) {
    // eq. (4)
    const double t2 = tau * tau;
    return (2.0 * t2 * eta_o - t2 + tau) / (t2 * eta_o + tau - eta_o + 1.0);
}

double eta_o_from_eta_a(double eta_a, double tau) {
    // eq. (4) solved for eta_O
    const double t2 = tau * tau;
    return (t2 - tau + eta_a * (tau + 1.0)) / (2.0 * t2 - eta_a * (t2 - 1.0));
}

bool Effects::any() const {
    for (const auto& e : kEffects) {
        const double def = Effects{}.*(e.member);
        if (this->*(e.member) != def) return true;
    }
    return false;
}

const std::vector<std::string>& Effects::names() {
    static const std::vector<std::string> names = [] {
        std::vector<std::string> v;
        for (const auto& e : kEffects) v.emplace_back(e.name);
        return v;
    }();
    return names;
}

void Effects::set(const std::string& name, double value) {
    const EffectSpec* e = find_effect(name);
    if (e == nullptr) {
        std::string known;
        for (const auto& k : kEffects) known += std::string(known.empty() ? "" : ", ") + k.name;
        throw SimError("unknown effect '" + name + "'; known effects: " + known);
    }
    if (!std::isfinite(value) || value < e->min || value > e->max) {
        throw SimError("effect " + name + " = " + fmt(value) + " is outside the allowed range [" +
                       fmt(e->min) + ", " + fmt(e->max) + "] " + e->unit);
    }
    this->*(e->member) = value;
}

Effects::Range Effects::range(const std::string& name) {
    const EffectSpec* e = find_effect(name);
    if (e == nullptr) throw SimError("unknown effect '" + name + "'");
    return {e->min, e->max, e->unit};
}

double Effects::get(const std::string& name) const {
    const EffectSpec* e = find_effect(name);
    if (e == nullptr) throw SimError("unknown effect '" + name + "'");
    return this->*(e->member);
}

double EmaParams::plant_inertia_kgm2() const {
    return effects.true_inertia_kgm2 > 0.0 ? effects.true_inertia_kgm2 : j_kgm2;
}

EmaParams EmaParams::datasheet() {
    EmaParams p;
    p.eta_a = eta_a_from_eta_o(p.eta_o, p.tau);
    return p;
}

void EmaParams::validate() const {
    std::string problems;
    for (const auto& f : kFields) {
        const double v = this->*(f.member);
        const bool low_ok = f.min_inclusive ? v >= f.min : v > f.min;
        const bool high_ok = f.max_inclusive ? v <= f.max : v < f.max;
        if (!std::isfinite(v) || !low_ok || !high_ok) {
            problems += "\n  " + std::string(f.name) + " = " + fmt(v) + " is outside the allowed range " +
                        range_text(f) + " " + f.unit;
        }
    }
    if (std::isfinite(fsj_nm) && std::isfinite(fdj_nm) && fsj_nm < fdj_nm) {
        problems += "\n  fsj_nm = " + fmt(fsj_nm) + " must be >= fdj_nm = " + fmt(fdj_nm) +
                    " (static friction is not below dynamic friction)";
    }
    for (const auto& e : kEffects) {
        const double v = effects.*(e.member);
        if (!std::isfinite(v) || v < e.min || v > e.max) {
            problems += "\n  effects." + std::string(e.name) + " = " + fmt(v) + " is outside the allowed range [" +
                        fmt(e.min) + ", " + fmt(e.max) + "] " + e.unit;
        }
    }
    for (std::size_t i = 0; i < terms.size(); ++i) {
        try {
            validate_term(terms[i], "terms[" + std::to_string(i) + "]");
        } catch (const SimError& e) {
            problems += std::string("\n  ") + e.what();
        }
    }
    if (!problems.empty()) throw SimError("invalid EMA parameters:" + problems);
}

EmaParams EmaParams::from_json(const nlohmann::json& j, const std::string& where) {
    if (!j.is_object()) throw SimError(where + ": expected a JSON object of parameters");
    EmaParams p = datasheet();
    bool eta_a_given = false;
    bool eta_o_given = false;
    std::string problems;
    for (const auto& [key, value] : j.items()) {
        if (key == "effects") {
            if (!value.is_object()) {
                problems += "\n  " + where + ".effects: expected an object";
                continue;
            }
            for (const auto& [ekey, evalue] : value.items()) {
                const EffectSpec* e = find_effect(ekey);
                if (e == nullptr) {
                    problems += "\n  " + where + ".effects." + ekey + ": unknown effect";
                } else if (!evalue.is_number()) {
                    problems += "\n  " + where + ".effects." + ekey + ": expected a number, got " + evalue.dump();
                } else {
                    p.effects.*(e->member) = evalue.get<double>();
                }
            }
            continue;
        }
        if (key == "terms") {
            if (!value.is_array()) {
                problems += "\n  " + where + ".terms: expected an array";
                continue;
            }
            for (std::size_t i = 0; i < value.size(); ++i) {
                try {
                    p.terms.push_back(term_from_json(value[i], where + ".terms[" + std::to_string(i) + "]"));
                } catch (const SimError& e) {
                    problems += std::string("\n  ") + e.what();
                }
            }
            continue;
        }
        const FieldSpec* spec = nullptr;
        for (const auto& f : kFields) {
            if (key == f.name) spec = &f;
        }
        if (spec == nullptr) {
            problems += "\n  " + where + "." + key + ": unknown parameter";
        } else if (!value.is_number()) {
            problems += "\n  " + where + "." + key + ": expected a number, got " + value.dump();
        } else {
            p.*(spec->member) = value.get<double>();
            eta_a_given = eta_a_given || key == "eta_a";
            eta_o_given = eta_o_given || key == "eta_o";
        }
    }
    if (!problems.empty()) throw SimError("invalid parameter file:" + problems);
    if (eta_a_given && !eta_o_given) {
        p.eta_o = eta_o_from_eta_a(p.eta_a, p.tau);
    } else if (!eta_a_given) {
        p.eta_a = eta_a_from_eta_o(p.eta_o, p.tau);
    }
    p.validate();
    return p;
}

EmaParams EmaParams::from_json_file(const std::string& path) {
    std::string error;
    const auto j = io::read_bounded_json_file(path, error);
    if (!j) throw SimError(error == "cannot open" ? "cannot open parameter file " + path : path + ": " + error);
    return from_json(*j, path);
}

nlohmann::json EmaParams::to_json() const {
    nlohmann::json j;
    for (const auto& f : kFields) j[f.name] = this->*(f.member);
    nlohmann::json e = nlohmann::json::object();
    for (const auto& s : kEffects) e[s.name] = effects.*(s.member);
    j["effects"] = e;
    if (!terms.empty()) {
        j["terms"] = nlohmann::json::array();
        for (const auto& t : terms) j["terms"].push_back(sim::to_json(t));
    }
    return j;
}

}  // namespace emadiag::sim
