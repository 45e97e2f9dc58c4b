#include "discovery/many_run/multi_run.hpp"

#include "core/emadiag_error.hpp"
#include "discovery/many_run/across_loads.hpp"
#include "discovery/many_run/breakaway_across.hpp"
#include "discovery/model/fit_parameter.hpp"
#include "discovery/physics_names.hpp"
#include "discovery/screening/screen_windows.hpp"
#include "estimation/health_estimate.hpp"
#include "discovery/screening/term_library.hpp"

#include <algorithm>
#include <cmath>
#include <map>

namespace emadiag::discovery {
namespace {

/// Runs are stacked with one unused sample between them (the comparison mask is 0 at every run's
/// first and last sample), so no window of the screening spans two runs.
void append(RunSignals& all, const RunSignals& s, const std::vector<char>& mask, std::vector<char>& all_mask) {
    if (all.size() == 0) {
        all.k_t_nm_per_a = s.k_t_nm_per_a;
        all.j_kgm2 = s.j_kgm2;
        all.tau = s.tau;
        all.sample_period_s = s.sample_period_s;
    }
    auto cat = [](auto& a, const auto& b) { a.insert(a.end(), b.begin(), b.end()); };
    cat(all.t_s, s.t_s);
    cat(all.current_a, s.current_a);
    cat(all.speed_rad_s, s.speed_rad_s);
    cat(all.theta_m_rad, s.theta_m_rad);
    cat(all.theta_start_rad, s.theta_start_rad);
    cat(all.load_torque_nm, s.load_torque_nm);
    cat(all.accel_rad_s2, s.accel_rad_s2);
    cat(all.residual_torque_nm, s.residual_torque_nm);
    cat(all.slipping, s.slipping);
    cat(all_mask, mask);
}

/// The value compared across runs for a step: its first term's coefficient, or its first fitted effect.
bool step_value(const DiscoveryStep& st, std::string& parameter, double& value, double& se) {
    if (!st.added_terms.empty()) {
        parameter = st.added_terms.front().basis_text();
        value = st.added_terms.front().coefficient;
        se = st.added_terms.front().std_error;
        return true;
    }
    for (const auto& f : st.fitted) {
        if (!f.parameter.is_health()) {
            parameter = f.name;
            value = f.value;
            se = f.std_error;
            return true;
        }
    }
    return false;
}

/// 2. Joint screening of what each run's own model leaves (`analysed[i]` the run of out.reports[i]),
/// and the confirmation of an accepted block on every run's own model.
void joint_screening(AcrossRunsReport& out, const std::vector<const Run*>& analysed) {
    RunSignals all;
    std::vector<char> all_mask;
    ScreenInput in;
    std::vector<std::size_t> offsets;
    std::vector<RunSignals> own, sims;
    for (std::size_t i = 0; i < out.reports.size(); ++i) {
        const Run& run = *analysed[i];
        const RunSignals s = run_signals(run);
        const sim::EmaParams& p = out.reports[i].model.params;
        const RunSignals m = resimulate_signals(resim_target(run), p);
        const std::vector<char> mask = comparison_mask(s, m);
        offsets.push_back(all.size());
        append(all, s, mask, all_mask);
        for (std::size_t k = 0; k < s.size(); ++k) in.residual_nm.push_back(s.residual_torque_nm[k] - m.residual_torque_nm[k]);
        std::vector<FitParameter> names = {FitParameter::fdj()};
        for (const auto& h : out.reports[i].model.health) {
            if (h.name == kParamEtaO && (h.source == "estimated" || h.source == "refit")) names.push_back(FitParameter::eta_o());
        }
        for (const auto& name : names) {
            std::vector<double> col(offsets.back(), 0.0);
            const auto c = sensitivity(run, p, m, name);
            col.insert(col.end(), c.begin(), c.end());
            in.base_columns.push_back(col);
        }
        own.push_back(s);
        sims.push_back(m);
    }
    for (auto& c : in.base_columns) c.resize(all.size(), 0.0);
    in.mask = all_mask;
    out.joint = screen_generated(all, in, generated_library(all));
    if (!out.joint.ranking.empty() && out.joint.ranking.front().accepted) {
        // A periodic block's period refined as for one run (on the stacked residual).
        const std::vector<sim::Term> joint_terms = refine_period(all, in, out.joint.ranking.front(), 1);
        // Confirmation: the joint terms added to every run's own model, re-simulated.
        double before = 0, after = 0;
        for (std::size_t i = 0; i < out.reports.size(); ++i) {
            sim::EmaParams q = out.reports[i].model.params;
            for (const auto& t : joint_terms) q.terms.push_back(t);
            const RunSignals m = resimulate_signals(resim_target(*analysed[i]), q);
            const double b = trajectory_error(own[i], sims[i], out.reports[i].floor).cost;
            const double a = trajectory_error(own[i], m, out.reports[i].floor).cost;
            out.joint_cost_before.push_back(b);
            out.joint_cost_after.push_back(a);
            before += b;
            after += a;
        }
        out.joint_confirmed = after < before;
        if (out.joint_confirmed) {
            out.joint_terms = joint_terms;
            const PhysicsName n = physics_name(joint_terms.front());
            out.joint_key = n.key;
            out.joint_text = n.text;
        }
    }
}

/// 3. The effects found in two runs or more, compared across the runs.
void compare_effects(AcrossRunsReport& out) {
    std::map<std::string, AcrossRunsEffect> by_key;
    std::vector<std::string> order;
    for (std::size_t i = 0; i < out.reports.size(); ++i) {
        for (const auto& st : out.reports[i].steps) {
            if (!st.added && st.added_terms.empty()) continue;
            std::string parameter;
            double v = 0, se = 0;
            if (!step_value(st, parameter, v, se)) continue;
            auto& e = by_key[st.name_key + "|" + parameter];
            if (e.key.empty()) order.push_back(st.name_key + "|" + parameter);
            e.key = st.name_key;
            e.text = st.name_text;
            e.parameter = parameter;
            e.runs.push_back(i);
            e.values.push_back(v);
            e.std_errors.push_back(std::max(se, 1e-300));
        }
    }
    for (const auto& k : order) {
        AcrossRunsEffect e = by_key[k];
        if (e.runs.size() < 2) continue;
        double sw = 0, swv = 0, swx = 0, swxx = 0, swxv = 0;
        for (std::size_t j = 0; j < e.runs.size(); ++j) {
            const double w = 1.0 / (e.std_errors[j] * e.std_errors[j]);
            const double x = static_cast<double>(e.runs[j]);
            sw += w;
            swv += w * e.values[j];
            swx += w * x;
            swxx += w * x * x;
            swxv += w * x * e.values[j];
        }
        e.mean = swv / sw;
        for (std::size_t j = 0; j < e.runs.size(); ++j) e.chi2 += std::pow((e.values[j] - e.mean) / e.std_errors[j], 2);
        const double det = sw * swxx - swx * swx;
        if (det > 0) {
            e.slope_per_run = (sw * swxv - swx * swv) / det;
            e.slope_se = std::sqrt(sw / det);
        }
        const double dof = static_cast<double>(e.runs.size() - 1);
        const double z = (e.chi2 - dof) / std::sqrt(2.0 * dof);
        e.changes = z > kStructureMinZ / 2 && e.slope_se > 0 && std::abs(e.slope_per_run) > 3.0 * e.slope_se;
        out.effects.push_back(e);
    }
}

}  // namespace

AcrossRunsReport discover_runs(const std::vector<Run>& runs, const std::vector<std::string>& labels,
                               const DiscoveryOptions& options) {
    if (runs.size() != labels.size()) throw EmadiagError("discover_runs: runs and labels differ in number");
    AcrossRunsReport out;
    // A run longer than options.max_samples is analysed on its first window, in every comparison
    // (discover, breakaway_across, across_loads), as discover() analyses it alone.
    std::vector<Run> windows;
    windows.reserve(runs.size());
    for (const auto& r : runs) {
        windows.push_back(r.samples.size() > options.max_samples ? analysis_window(r, options.max_samples) : Run{});
    }
    const auto run_at = [&](std::size_t i) -> const Run& {
        return runs[i].samples.size() > options.max_samples ? windows[i] : runs[i];
    };
    std::vector<const Run*> analysed;
    std::vector<std::size_t> analysed_index;  // into `runs`
    std::vector<std::size_t> brk_runs;
    for (std::size_t i = 0; i < runs.size(); ++i) {
        if (runs[i].sequence == sim::Sequence::Brk) {  // compared with a DYN run below
            brk_runs.push_back(i);
            continue;
        }
        try {
            out.reports.push_back(discover(run_at(i), options));
            out.reports.back().total_samples = runs[i].samples.size();
            if (runs[i].samples.size() > options.max_samples) out.reports.back().notes.push_back(out.reports.back().analysis_text());
            out.labels.push_back(labels[i]);
            analysed.push_back(&run_at(i));
            analysed_index.push_back(i);
        } catch (const EmadiagError& e) {
            out.skipped.push_back(labels[i] + ": " + e.what());
        }
    }
    // Across DYN and BRK: each BRK run against the nearest analysed run in the order given (the
    // earlier one on a tie: a session's DYN run comes before its BRK run).
    for (std::size_t b : brk_runs) {
        if (analysed.empty()) {
            out.skipped.push_back(labels[b] + ": a BRK run is compared with a DYN run of the same actuator (breakaway "
                                              "thresholds against its model), and none could be analysed");
            continue;
        }
        std::size_t pick = 0;
        for (std::size_t k = 1; k < analysed_index.size(); ++k) {
            const auto dist = [&](std::size_t i) { return i > b ? i - b : b - i; };
            if (dist(analysed_index[k]) < dist(analysed_index[pick])) pick = k;
        }
        out.breakaways.push_back(breakaway_across(run_at(b), labels[b], *analysed[pick], out.labels[pick], out.reports[pick]));
    }
    if (out.reports.empty()) {
        std::string why;
        for (const auto& s : out.skipped) why += "\n  " + s;
        throw EmadiagError("discovery: none of the " + std::to_string(runs.size()) + " runs can be analysed:" + why);
    }
    // 2. Joint screening of what each run's own model leaves (needs two runs or more).
    if (out.reports.size() >= 2 && options.open_world) joint_screening(out, analysed);
    // Across load cases: an efficiency change or a friction that follows the load on one run.
    if (options.open_world && out.reports.size() >= 2) out.loads = across_loads(analysed, out.labels, out.reports);
    compare_effects(out);
    return out;
}

std::string AcrossRunsReport::summary() const {
    std::string s;
    for (std::size_t i = 0; i < reports.size(); ++i) s += labels[i] + ": " + reports[i].summary() + "\n";
    for (const auto& k : skipped) s += "skipped " + k + "\n";
    if (!joint_terms.empty()) {
        s += "across the runs: " + joint_text + " (";
        for (const auto& t : joint_terms) s += t.text() + (&t == &joint_terms.back() ? "" : ", ");
        s += "), found only in the runs together\n";
    }
    if (loads.ran) {
        s += "across load cases (";
        for (std::size_t i = 0; i < loads.load_cases.size(); ++i) s += (i ? ", " : "") + loads.load_cases[i];
        s += "): " + loads.verdict + "\n";
    }
    for (const auto& b : breakaways) s += "across DYN and BRK (" + b.brk_label + " with " + b.dyn_label + "): " + b.verdict + "\n";
    for (const auto& e : effects) {
        s += "across the runs: " + e.text + " (" + e.parameter + ") in " + std::to_string(e.runs.size()) + " runs, mean " +
             fmt4(e.mean) + (e.changes ? ", CHANGES from run to run: slope " + fmt4(e.slope_per_run) + " +/- " +
                                            fmt4(e.slope_se) + " per run"
                                      : ", consistent across the runs") +
             "\n";
    }
    return s;
}

nlohmann::json AcrossRunsReport::to_json() const {
    nlohmann::json j;
    j["schema"] = "emadiag-discover-runs";
    j["runs"] = nlohmann::json::array();
    for (std::size_t i = 0; i < reports.size(); ++i) j["runs"].push_back({{"label", labels[i]}, {"report", reports[i].to_json()}});
    j["skipped"] = skipped;
    nlohmann::json jr = nlohmann::json::array();
    for (std::size_t i = 0; i < joint.ranking.size() && i < 5; ++i) {
        const auto& g = joint.ranking[i];
        nlohmann::json terms = nlohmann::json::array();
        for (const auto& t : g.terms) terms.push_back(sim::to_json(t));
        jr.push_back({{"family", g.family}, {"terms", terms}, {"delta_bic", g.delta_bic}, {"passes_criterion", g.accepted},
                      {"reason", g.reason}});
    }
    j["joint_screening"] = jr;
    j["joint_finding"] = nullptr;
    if (!joint_terms.empty()) {
        nlohmann::json terms = nlohmann::json::array();
        for (const auto& t : joint_terms) terms.push_back(sim::to_json(t));
        j["joint_finding"] = {{"name", joint_key}, {"physics", joint_text}, {"terms", terms},
                              {"trajectory_cost_before", joint_cost_before}, {"trajectory_cost_after", joint_cost_after}};
    }
    j["across_load_cases"] = loads.to_json();
    j["across_dyn_and_brk"] = nlohmann::json::array();
    for (const auto& b : breakaways) j["across_dyn_and_brk"].push_back(b.to_json());
    j["effects_across_runs"] = nlohmann::json::array();
    for (const auto& e : effects) {
        j["effects_across_runs"].push_back({{"name", e.key}, {"physics", e.text}, {"parameter", e.parameter},
                                            {"runs", e.runs}, {"values", e.values}, {"std_errors", e.std_errors},
                                            {"mean", e.mean}, {"chi2", e.chi2}, {"slope_per_run", e.slope_per_run},
                                            {"slope_se", e.slope_se}, {"changes", e.changes}});
    }
    j["summary"] = summary();
    return j;
}

FindingRecord finding_record(const DiscoveryReport& report) { return {report.model.to_json(), report.summary()}; }

FindingRecord finding_record(const AcrossRunsReport& report) {
    std::size_t best = 0;
    std::size_t most = 0;
    for (std::size_t i = 0; i < report.reports.size(); ++i) {
        const std::size_t n = report.reports[i].added_effects().size();
        if (n > most) {
            most = n;
            best = i;
        }
    }
    FindingRecord r{report.reports.at(best).model.to_json(), report.summary()};
    if (!report.joint_terms.empty()) {
        nlohmann::json terms = nlohmann::json::array();
        for (const auto& t : report.joint_terms) terms.push_back(sim::to_json(t));
        r.model["joint_terms"] = terms;
    }
    nlohmann::json rest = nlohmann::json::array();
    for (const auto& b : report.breakaways) {
        for (const auto& t : b.terms) rest.push_back(sim::to_json(t));
    }
    if (!rest.empty()) r.model["rest_offset_terms"] = rest;
    if (report.loads.ran && !report.loads.key.empty()) r.model["across_load_cases"] = report.loads.to_json()["finding"];
    return r;
}

}  // namespace emadiag::discovery
