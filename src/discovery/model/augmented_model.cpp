#include "discovery/model/augmented_model.hpp"

#include "core/emadiag_error.hpp"
#include "discovery/screening/candidate_effect.hpp"
#include "emadiag/sim/sim_error.hpp"
#include "estimation/health_estimate.hpp"
#include "estimation/health_parameter.hpp"

#include <optional>

namespace emadiag::discovery {

nlohmann::json to_json(const ErrorMetrics& e) {
    return {{"current_rms_A", e.current_rms_a},
            {"residual_torque_rms_Nm", e.residual_torque_rms_nm},
            {"residual_torque_window_rms_Nm", e.residual_torque_window_rms_nm},
            {"speed_rms_rad_s", e.speed_rms_rad_s},
            {"theta_rms_rad", e.theta_rms_rad},
            {"samples", e.samples},
            {"torque_samples", e.torque_samples}};
}

nlohmann::json AugmentedModel::to_json() const {
    nlohmann::json j;
    j["version"] = kModelJsonVersion;
    j["base"] = kModelBase;
    j["health"] = nlohmann::json::object();
    for (const auto& h : health) {
        j["health"][h.name] = {{"value", h.value}, {"std_error", h.std_error}, {"source", h.source}, {"note", h.note}};
    }
    j["terms"] = nlohmann::json::array();
    for (const auto& t : terms) j["terms"].push_back({{"effect", t.effect}, {"value", t.value}, {"std_error", t.std_error}});
    for (std::size_t i = 0; i < params.terms.size(); ++i) {
        nlohmann::json jt = sim::to_json(params.terms[i]);
        if (i < term_keys.size()) jt["name"] = term_keys[i];
        if (i < term_texts.size()) jt["physics"] = term_texts[i];
        j["terms"].push_back(jt);
    }
    j["error_before"] = discovery::to_json(error_before);
    j["error_after"] = discovery::to_json(error_after);
    j["sim_params"] = params.to_json();
    return j;
}

void apply_model(const nlohmann::json& model, sim::EmaParams& params) {
    std::vector<std::string> problems;
    if (!model.is_object()) throw EmadiagError("model: expected a JSON object");
    if (!model.contains("version") || model["version"] != kModelJsonVersion) {
        problems.push_back("model.version: expected " + std::to_string(kModelJsonVersion) + ", got " +
                           (model.contains("version") ? model["version"].dump() : std::string("nothing")));
    }
    sim::EmaParams p = params;
    bool eta_o_set = false, eta_a_set = false;
    if (model.contains("health")) {
        if (!model["health"].is_object()) problems.push_back("model.health: expected an object");
        for (const auto& [name, v] : model["health"].items()) {
            const std::string where = "model.health." + name + ".value";
            if (!v.is_object() || !v.contains("value") || !v["value"].is_number()) {
                problems.push_back(where + ": expected a number");
                continue;
            }
            const double x = v["value"].get<double>();
            const std::optional<HealthParameter> parameter = parse_health_parameter(name);
            if (!parameter) {
                problems.push_back("model.health." + name + ": unknown health parameter");
                continue;
            }
            switch (*parameter) {
                case HealthParameter::Fdj: p.fdj_nm = x; break;
                case HealthParameter::Fsj: p.fsj_nm = x; break;
                case HealthParameter::EtaO: p.eta_o = x; eta_o_set = true; break;
                case HealthParameter::EtaA: p.eta_a = x; eta_a_set = true; break;
            }
        }
    }
    if (eta_o_set && !eta_a_set) p.eta_a = sim::eta_a_from_eta_o(p.eta_o, p.tau);
    if (eta_a_set && !eta_o_set) p.eta_o = sim::eta_o_from_eta_a(p.eta_a, p.tau);
    std::vector<sim::Term> data_terms;
    bool has_data_terms = false;
    if (model.contains("terms")) {
        if (!model["terms"].is_array()) problems.push_back("model.terms: expected an array");
        std::size_t i = 0;
        for (const auto& t : model["terms"]) {
            const std::string where = "model.terms[" + std::to_string(i++) + "]";
            if (t.is_object() && t.contains("basis")) {
                has_data_terms = true;
                try {
                    data_terms.push_back(sim::term_from_json(t, where));
                } catch (const std::exception& e) {
                    problems.push_back(e.what());
                }
                continue;
            }
            if (!t.is_object() || !t.contains("effect") || !t["effect"].is_string()) {
                problems.push_back(where + ".effect: expected a string");
                continue;
            }
            if (!t.contains("value") || !t["value"].is_number()) {
                problems.push_back(where + ".value: expected a number");
                continue;
            }
            try {
                p.effects.set(effect_sim_name(t["effect"].get<std::string>()), t["value"].get<double>());
            } catch (const std::exception& e) {
                problems.push_back(where + ": " + e.what());
            }
        }
    }
    if (has_data_terms) p.terms = data_terms;
    if (problems.empty()) {
        try {
            p.validate();
        } catch (const sim::SimError& e) {
            problems.push_back(e.what());
        }
    }
    if (!problems.empty()) {
        std::string msg = "invalid discovery model:";
        for (const auto& s : problems) msg += "\n  " + s;
        throw EmadiagError(msg);
    }
    params = p;
}

}  // namespace emadiag::discovery
