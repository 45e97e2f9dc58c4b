// The discovery report: its summary, the effects added and the JSON (discovery.hpp).
#include "discovery/discovery.hpp"

#include "discovery/screening/screen_windows.hpp"
#include "discovery/stages/context.hpp"

#include <cstdio>
#include <sstream>

namespace emadiag::discovery {

using pipeline::library_effect_text;

namespace {

/// Entries of the generated library's ranking written per step in the JSON report.
constexpr std::size_t kJsonGenericRanking = 8;

/// One torque round in the JSON report.
nlohmann::json step_json(const DiscoveryStep& s) {
    nlohmann::json js;
    js["screening_samples"] = s.screen.samples;
    js["screening_windows"] = s.screen.windows;
    js["base_residual_rms_Nm"] = s.screen.base_rms_nm;
    js["ranking"] = nlohmann::json::array();
    for (const auto& c : s.screen.ranking) {
        js["ranking"].push_back({{"effect", effect_name(c.shape.kind)},
                                 {"signature", signature_text(c.shape.kind)},
                                 {"shape", shape_text(c.shape)},
                                 {"amplitude", c.amplitude},
                                 {"amplitude_se", c.amplitude_se},
                                 {"delta_bic", c.delta_bic},
                                 {"explained_rms_Nm", c.explained_rms_nm},
                                 {"peak_torque_Nm", c.peak_torque_nm},
                                 {"rss_ratio", c.rss_ratio},
                                 {"passes_criterion", c.accepted},
                                 {"reason", c.reason}});
    }
    js["added"] = s.added || !s.added_terms.empty() ? nlohmann::json(s.name_key) : nlohmann::json(nullptr);
    if (!s.name_text.empty()) js["physics"] = s.name_text;
    js["added_terms"] = nlohmann::json::array();
    for (const auto& t : s.added_terms) js["added_terms"].push_back(sim::to_json(t));
    js["generic_ranking"] = nlohmann::json::array();
    for (std::size_t i = 0; i < s.generic.ranking.size() && i < kJsonGenericRanking; ++i) {
        const auto& g = s.generic.ranking[i];
        nlohmann::json terms = nlohmann::json::array();
        for (const auto& t : g.terms) terms.push_back(sim::to_json(t));
        js["generic_ranking"].push_back({{"family", g.family}, {"terms", terms}, {"delta_bic", g.delta_bic},
                                         {"explained_rms_Nm", g.explained_rms_nm}, {"peak_torque_Nm", g.peak_torque_nm},
                                         {"cv_gain", g.checked ? nlohmann::json(g.cv_gain) : nlohmann::json(nullptr)},
                                         {"stability", g.checked ? nlohmann::json(g.stability) : nlohmann::json(nullptr)},
                                         {"passes_criterion", g.accepted}, {"reason", g.reason}});
    }
    js["generic_shapes"] = s.generic.shapes;
    js["hypotheses"] = nlohmann::json::array();
    for (const auto& h : s.hypotheses) {
        js["hypotheses"].push_back({{"name", h.key}, {"physics", h.text}, {"change", h.change},
                                    {"trajectory_cost", h.cost}, {"current_rms_A", h.error.current_a},
                                    {"speed_rms_rad_s", h.error.speed_rad_s}, {"theta_rms_rad", h.error.theta_rad},
                                    {"load_rms_Nm", h.error.load_nm}, {"refit_on_trajectory", h.refit_on_trajectory}});
    }
    if (!s.hypotheses.empty()) js["hypotheses_equivalent"] = s.equivalent;
    js["trajectory_cost_before"] = s.trajectory_before;
    js["trajectory_cost_after"] = s.trajectory_after;
    if (!s.rejected_by_fit.empty()) js["rejected_by_fit"] = s.rejected_by_fit;
    if (!s.withheld.empty()) js["withheld"] = s.withheld;
    js["fitted"] = nlohmann::json::array();
    for (const auto& f : s.fitted) js["fitted"].push_back({{"name", f.name}, {"value", f.value}, {"std_error", f.std_error}});
    js["simulations"] = s.simulations;
    js["fit_delta_bic"] = s.fit_delta_bic;
    if (s.added) js["error_after"] = discovery::to_json(s.error_after);
    return js;
}

/// The low-speed stage in the JSON report.
nlohmann::json low_speed_json(const LowSpeedStage& low_speed) {
    nlohmann::json ls;
    ls["ran"] = low_speed.ran;
    if (!low_speed.skipped.empty()) ls["skipped"] = low_speed.skipped;
    if (low_speed.ran) {
        ls["trajectory_rows"] = low_speed.rows;
        ls["trajectory_cost_before"] = low_speed.cost_before;
        ls["base_cost"] = low_speed.base_cost;
        ls["ranking"] = nlohmann::json::array();
        for (const auto& ev : low_speed.ranking) {
            ls["ranking"].push_back({{"stribeck_speed_rad_s", ev.stribeck_speed_rad_s}, {"amplitude_Nm", ev.amplitude_nm},
                                     {"amplitude_se_Nm", ev.amplitude_se_nm}, {"delta_bic", ev.delta_bic},
                                     {"sign_ok", ev.sign_ok}});
        }
        ls["screen_passes"] = low_speed.screen_passes;
        if (low_speed.screen_passes) {
            ls["trajectory_cost_health_only"] = low_speed.cost_health_only;
            ls["trajectory_cost_with"] = low_speed.cost_with;
            ls["fit_delta_bic"] = low_speed.fit_delta_bic;
            ls["explained"] = low_speed.explained;
            ls["profile"] = nlohmann::json::array();
            for (const auto& pr : low_speed.profile) {
                ls["profile"].push_back({{"stribeck_speed_rad_s", pr[0]}, {"amplitude_Nm", pr[1]}, {"trajectory_cost", pr[2]}});
            }
            ls["fitted"] = nlohmann::json::array();
            for (const auto& f : low_speed.fitted) {
                ls["fitted"].push_back({{"name", f.name}, {"value", f.value}, {"std_error", f.std_error}});
            }
        }
        ls["simulations"] = low_speed.simulations;
        ls["added"] = low_speed.added;
        ls["refit_of_torque"] = low_speed.refit_of_torque;
        ls["verdict"] = low_speed.verdict;
    }
    return ls;
}

/// The efficiency-or-friction alternative in the JSON report.
nlohmann::json efficiency_json(const EfficiencyAlternative& ea) {
    nlohmann::json e = {{"ran", ea.ran}};
    if (!ea.ran) {
        e["skipped"] = ea.skipped;
    } else {
        e["eta_o"] = ea.eta_o;
        e["eta_o_std_error"] = ea.eta_o_se;
        e["eta_o_datasheet"] = ea.eta_o_datasheet;
        e["friction"] = ea.key.empty() ? nlohmann::json(nullptr) : nlohmann::json(ea.key);
        if (!ea.key.empty()) {
            e["physics"] = ea.text;
            e["change"] = ea.change;
            e["trajectory_cost_model"] = ea.cost_model;
            e["trajectory_cost_alternative"] = ea.cost_alternative;
        }
        e["equivalent"] = ea.equivalent;
        e["favoured"] = ea.favoured;
        e["verdict"] = ea.verdict;
    }
    return e;
}

}  // namespace

std::vector<std::string> DiscoveryReport::added_effects() const {
    std::vector<std::string> v;
    for (const auto& s : steps) {
        if (s.added || !s.added_terms.empty()) v.push_back(s.name_key);
    }
    if (low_speed.added && !low_speed.refit_of_torque) v.push_back(effect_name(EffectKind::Stribeck));
    for (const auto& f : sensor_findings) v.push_back(f.key);
    if (efficiency.favoured) v.push_back(efficiency.key);
    return v;
}

const StructureReport* DiscoveryReport::unexplained() const {
    const StructureReport* best = nullptr;
    for (const auto& r : structure) {
        if (r.significant && (best == nullptr || r.z > best->z)) best = &r;
    }
    return best;
}

std::string DiscoveryReport::summary() const {
    std::string out;
    for (const auto& s : steps) {
        if (!s.added && s.added_terms.empty()) continue;
        out += (out.empty() ? "found: " : "; ") + s.name_text;
        if (s.equivalent && s.hypotheses.size() >= 2) {
            out += " (equivalent on this run: " + s.hypotheses[1].text + ")";
        }
    }
    if (low_speed.added && !low_speed.refit_of_torque) {
        out += (out.empty() ? "found: " : "; ") + library_effect_text(EffectKind::Stribeck) + " (by the trajectory)";
    }
    if (efficiency.equivalent || efficiency.favoured) {
        char buf[200];
        std::snprintf(buf, sizeof buf, "eta_O %.4g off the datasheet %.4g", efficiency.eta_o, efficiency.eta_o_datasheet);
        out += (out.empty() ? "found: " : "; ") + std::string(buf) +
               (efficiency.equivalent ? ", or equivalently on this run " : ", which the trajectory explains better as ") +
               efficiency.text + " at the datasheet eta_O";
    }
    for (const auto& f : sensor_findings) out += (out.empty() ? "found: " : "; ") + f.text;
    if (const StructureReport* u = unexplained()) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "%.2f x the noise floor (z = %.1f)", u->rms / u->floor, u->z);
        out += std::string(out.empty() ? "" : "; ") + "unexplained structure in the " + u->channel + " residual: " + buf;
        if (!u->dependence.empty()) {
            std::snprintf(buf, sizeof buf, "%.2f", u->dependence.front().variance_explained);
            out += ", depends most on " + u->dependence.front().variable + " (binned variance explained " + buf + ")";
        }
    } else if (out.empty()) {
        out = "no significant discrepancy: the residual is consistent with the run's noise floor";
    }
    return out;
}

std::optional<double> DiscoveryReport::term_value(const std::string& sim_name) const {
    const std::string field = effect_field(sim_name);
    for (const auto& t : model.terms) {
        if (t.effect == field) return t.value;
    }
    return std::nullopt;
}

nlohmann::json DiscoveryReport::to_json() const {
    nlohmann::json j;
    j["schema"] = "emadiag-discover";
    j["version"] = kModelJsonVersion;
    j["run"] = {{"case", sim::to_string(load_case)}, {"sequence", sim::to_string(sequence)}, {"samples", samples}, {"total_samples", total_samples}};
    if (total_samples > samples) j["run"]["analysed"] = analysis_text();
    j["added_effects"] = added_effects();
    j["baseline_health"] = nlohmann::json::object();
    for (const auto& h : baseline_health) {
        j["baseline_health"][h.name] = {{"value", h.value}, {"std_error", h.std_error}, {"source", h.source}, {"note", h.note}};
    }
    j["steps"] = nlohmann::json::array();
    for (const auto& s : steps) j["steps"].push_back(step_json(s));
    j["model"] = model.to_json();
    const auto ratio = [](double a, double b) { return b > 0 ? nlohmann::json(a / b) : nlohmann::json(nullptr); };
    j["ratio_before_after"] = {
        {"current_rms", ratio(model.error_before.current_rms_a, model.error_after.current_rms_a)},
        {"residual_torque_rms", ratio(model.error_before.residual_torque_rms_nm, model.error_after.residual_torque_rms_nm)},
        {"residual_torque_window_rms",
         ratio(model.error_before.residual_torque_window_rms_nm, model.error_after.residual_torque_window_rms_nm)}};
    j["noise_floor"] = {{"current_A", floor.current_a}, {"speed_rad_s", floor.speed_rad_s}, {"theta_rad", floor.theta_rad},
                        {"load_Nm", floor.load_nm}, {"torque_window_Nm", floor.torque_window_nm}};
    j["sensor_findings"] = nlohmann::json::array();
    for (const auto& f : sensor_findings) {
        j["sensor_findings"].push_back({{"name", f.key}, {"physics", f.text}, {"term", sim::to_json(f.term)},
                                        {"trajectory_cost_before", f.cost_before}, {"trajectory_cost_after", f.cost_after}});
    }
    j["low_speed_stage"] = low_speed_json(low_speed);
    j["efficiency_or_friction"] = efficiency_json(efficiency);
    j["trajectory_cost_before"] = trajectory_before.cost;
    j["trajectory_cost_after"] = trajectory_after.cost;
    j["residual_structure"] = nlohmann::json::array();
    for (const auto& r : structure) {
        nlohmann::json dep = nlohmann::json::array();
        for (const auto& d : r.dependence) dep.push_back({{"variable", d.variable}, {"variance_explained", d.variance_explained}});
        j["residual_structure"].push_back({{"channel", r.channel}, {"unit", r.unit}, {"rms", r.rms}, {"noise_floor", r.floor},
                                           {"chi2", r.chi2}, {"z", r.z}, {"n", r.n}, {"significant", r.significant},
                                           {"test", structure_test_text(r)}, {"dependence", dep}});
    }
    const StructureReport* u = unexplained();
    j["unexplained"] = u != nullptr ? nlohmann::json(u->channel) : nlohmann::json(nullptr);
    j["summary"] = summary();
    j["notes"] = notes;
    return j;
}

std::string DiscoveryReport::analysis_text() const {
    if (total_samples <= samples) return "";
    std::ostringstream os;
    os << "analysed " << samples << " of " << total_samples << " samples in 1 window (the run's first " << samples
       << " samples, t <= " << analysed_end_s << " s; limit kMaxAnalysedSamples = " << kMaxAnalysedSamples << ")";
    return os.str();
}

}  // namespace emadiag::discovery
