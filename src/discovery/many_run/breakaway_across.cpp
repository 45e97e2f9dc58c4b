#include "discovery/many_run/breakaway_across.hpp"

#include "core/emadiag_error.hpp"
#include "discovery/model/model_correction.hpp"
#include "discovery/model/fit_parameter.hpp"
#include "discovery/physics_names.hpp"
#include "discovery/screening/screen_windows.hpp"
#include "discovery/model/resimulation.hpp"
#include "discovery/model/run_signals.hpp"
#include "estimation/breakaway.hpp"
#include "estimation/health_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <optional>

namespace emadiag::discovery {
namespace {

/// The thresholds S_+ and S_- of a BRK run, with their standard errors; nullopt and `why` when
/// either breakaway is missing.
struct Thresholds {
    double up = 0, up_se = 0, down = 0, down_se = 0;
};
std::optional<Thresholds> thresholds(const Run& brk, std::string& why) {
    const BreakawayAnalysis a = analyse_breakaways(brk);
    Thresholds t;
    bool up = false, down = false;
    for (const auto& e : a.events) {
        if (e.direction > 0 && !up) {
            t.up = e.threshold_nm;
            t.up_se = e.threshold_se_nm;
            up = true;
        } else if (e.direction < 0 && !down) {
            t.down = e.threshold_nm;
            t.down_se = e.threshold_se_nm;
            down = true;
        }
    }
    if (up && down) return t;
    why = std::string("the BRK run's breakaway in ") + (up ? "the negative" : down ? "the positive" : "either") +
          " direction was not found";
    for (const auto& p : a.problems) why += "; " + p;
    return std::nullopt;
}

/// The constant terms a BRK run can see, each with a probe size of the order of the smallest fault
/// worth naming: a torque of 0.005 N m (motor side), a hinge-moment offset of 2 N m (surface side), a
/// current offset of 0.02 A, an angle offset of 0.002 rad.
struct Probe {
    sim::TermTarget target;
    double size;
};
constexpr Probe kProbes[] = {{sim::TermTarget::Torque, 0.005},
                             {sim::TermTarget::Hinge, 2.0},
                             {sim::TermTarget::Current, 0.02},
                             {sim::TermTarget::Theta, 0.002}};

/// A torque term that acts at rest: no factor of the speed.
bool acts_at_rest(const sim::Term& t) {
    return t.target == sim::TermTarget::Torque &&
           std::none_of(t.factors.begin(), t.factors.end(), [](const sim::TermFactor& f) { return f.signal == sim::TermSignal::Speed; });
}

sim::Term constant_term(sim::TermTarget target, double coefficient, double se = 0) {
    sim::Term t;
    t.target = target;
    t.coefficient = coefficient;
    t.std_error = se;
    return t;
}

/// Step 1: the measured thresholds of `brk`, the DYN model's (`p`) sensor errors taken out of it
/// first; nullopt with out.problem and out.verdict when they are not both found.
std::optional<Thresholds> measured_thresholds(const Run& brk, const sim::EmaParams& p, BreakawayAcross& out) {
    // 1. Measured thresholds. The DYN model's sensor errors are taken out of the measured BRK run
    // first (the breakaway analysis reads the recorded current and hinge moment: a recorded current
    // offset of 0.1 A hid a ramp end), and out of the model below: what is compared is the physics
    // at rest.
    ModelCorrection sensors;
    try {
        for (const auto& t : model_correction(p).terms) {
            if (t.target != sim::TermTarget::Torque) sensors.terms.push_back(t);
        }
    } catch (const EmadiagError&) {
        sensors.terms.clear();  // backlash: the samples cannot be corrected
    }
    if (!sensors.terms.empty()) {
        out.sensor_correction = sensors.text();
        std::string why_recorded;
        if (const auto recorded = thresholds(brk, why_recorded)) {
            out.as_recorded = "as recorded S+ " + fmt4(recorded->up) + ", S- " + fmt4(recorded->down) + " N m";
        } else {
            out.as_recorded = "as recorded: " + why_recorded;
        }
    }
    std::string why;
    const std::optional<Thresholds> meas = thresholds(sensors.terms.empty() ? brk : remove_model_effects(brk, sensors), why);
    if (!meas) {
        out.problem = why + (sensors.terms.empty() ? "" : " (with the DYN model's sensor errors removed: " + sensors.text() + ")");
        out.verdict = "not compared: " + out.problem;
        return std::nullopt;
    }
    out.up_nm = meas->up;
    out.up_se_nm = meas->up_se;
    out.down_nm = meas->down;
    out.down_se_nm = meas->down_se;
    out.asymmetry_se_nm = 0.5 * std::hypot(meas->up_se, meas->down_se);
    return meas;
}

/// Step 4: the constant terms that can explain the asymmetry, sized by it (and, in place of the DYN
/// model's torque terms that act at rest, `rest_terms`, by the asymmetry beyond the model without them:
/// sims.back()); sims[1 + i] is the BRK sequence re-simulated with probe i.
void size_hypotheses(BreakawayAcross& out, const Thresholds& meas, const Thresholds& model, const std::vector<Run>& sims,
                     const std::vector<sim::Term>& rest_terms) {
    std::string why;
    std::optional<double> asymmetry_bare;
    std::string replaced;
    if (!rest_terms.empty()) {
        if (const auto bare = thresholds(sims.back(), why)) asymmetry_bare = 0.5 * ((meas.up - bare->up) - (meas.down - bare->down));
        for (const auto& t : rest_terms) replaced += (replaced.empty() ? "" : ", ") + t.text();
    }
    for (std::size_t i = 0; i < std::size(kProbes); ++i) {
        const std::optional<Thresholds> pt = thresholds(sims[i + 1], why);
        if (!pt) continue;
        const double per_probe = 0.5 * ((pt->up - model.up) - (pt->down - model.down));
        if (std::abs(per_probe) < kBrkProbeMinZ * out.asymmetry_se_nm) continue;
        RestOffsetHypothesis h;
        h.asymmetry_per_unit = per_probe / kProbes[i].size;
        h.term = constant_term(kProbes[i].target, out.asymmetry_nm / h.asymmetry_per_unit,
                               out.asymmetry_se_nm / std::abs(h.asymmetry_per_unit));
        const PhysicsName n = physics_name(h.term);
        h.key = n.key;
        h.text = n.text;
        out.hypotheses.push_back(h);
        if (asymmetry_bare) {
            h.term.coefficient = *asymmetry_bare / h.asymmetry_per_unit;
            h.replaces = replaced;
            out.hypotheses.push_back(h);
        }
    }
}

/// Step 5: the DYN trajectory: the model's own health refitted on it, without and with each candidate;
/// the hypotheses sorted by their DYN cost, best first.
void refit_on_dyn(BreakawayAcross& out, const Run& dyn, const DiscoveryReport& dyn_report) {
    const RunSignals s = run_signals(dyn);
    std::vector<FitParameter> names = {FitParameter::fdj()};
    for (const auto& h : dyn_report.model.health) {
        if (h.name == kParamEtaO && (h.source == "estimated" || h.source == "refit")) names.push_back(FitParameter::eta_o());
    }
    const std::vector<char> no_mask(s.size(), char{1});  // not used by a fit on the trajectory
    sim::EmaParams dyn_p = dyn_report.model.params;
    out.fdj_before_nm = dyn_p.fdj_nm;
    dyn_p.fsj_nm = std::max(out.fsj_nm, dyn_p.fdj_nm);
    out.dyn_cost_before = trajectory_error(s, resimulate_signals(resim_target(dyn), dyn_p), dyn_report.floor).cost;
    auto refit = [&](const sim::EmaParams& start) {
        return fit_by_resimulation(dyn, s, start, names, no_mask, out.fsj_nm, kFitWindowSamples, nullptr, kMaxFitIterations,
                                   &dyn_report.floor);
    };
    out.dyn_cost_model = trajectory_error(s, refit(dyn_p).signals, dyn_report.floor).cost;
    for (auto& h : out.hypotheses) {
        sim::EmaParams q = dyn_p;
        if (!h.replaces.empty()) {
            std::erase_if(q.terms, acts_at_rest);  // the DYN model's torque terms are p's
        }
        q.terms.push_back(h.term);
        const FitResult f = refit(q);
        h.dyn_error = trajectory_error(s, f.signals, dyn_report.floor);
        h.dyn_cost = h.dyn_error.cost;
        for (const auto& v : f.values) {
            if (v.parameter == FitParameter::fdj()) {
                h.fdj_nm = v.value;
                h.fdj_se_nm = v.std_error;
            }
        }
    }
    std::stable_sort(out.hypotheses.begin(), out.hypotheses.end(),
                     [](const RestOffsetHypothesis& a, const RestOffsetHypothesis& b) { return a.dyn_cost < b.dyn_cost; });
}

/// The verdict of a significant asymmetry with hypotheses: the best one named unless the DYN trajectory
/// refutes it, with its runner-up of another name; `measured` describes the BRK thresholds.
void name_best(BreakawayAcross& out, const std::string& measured) {
    const RestOffsetHypothesis& best = out.hypotheses.front();
    const std::string dyn_text = "DYN trajectory cost " + fmt4(out.dyn_cost_model) + " with the model's own health refitted, " +
                                 fmt4(best.dyn_cost) + " with " + best.term.text();
    // The BRK run shows that the offset exists; the DYN run must not refute the candidate (its cost
    // no worse than the model's, or not told apart from it) and tells the candidates apart.
    if (best.dyn_cost > out.dyn_cost_model && !not_told_apart(best.dyn_cost, out.dyn_cost_model, kHypothesisRatio)) {
        out.rejected = true;
        out.verdict = "a constant offset at rest, NOT named: " + measured + "; the DYN trajectory refutes every candidate (" +
                      dyn_text + ")";
        return;
    }
    out.terms = {best.term};
    out.key = best.key;
    out.text = best.text;
    // The runner-up of another name (the same name added or in place of the DYN run's terms is one physics).
    const auto other = std::find_if(out.hypotheses.begin() + 1, out.hypotheses.end(),
                                    [&](const RestOffsetHypothesis& h) { return h.key != best.key; });
    if (other != out.hypotheses.end() && other != out.hypotheses.begin() + 1) {
        std::rotate(out.hypotheses.begin() + 1, other, other + 1);
    }
    out.equivalent = out.hypotheses.size() >= 2 && out.hypotheses[1].key != best.key &&
                     not_told_apart(best.dyn_cost, out.hypotheses[1].dyn_cost, kHypothesisRatio);
    out.verdict = "found across DYN and BRK: " + best.text + ", " + best.term.text() +
                  (best.replaces.empty() ? std::string() : ", in place of the DYN run's " + best.replaces) +
                  " (size from the BRK run: " + measured +
                  "; identity from the DYN run: " + dyn_text;
    if (out.equivalent) {
        out.verdict += "; NOT told apart from " + out.hypotheses[1].text + " (" + out.hypotheses[1].term.text() +
                       (out.hypotheses[1].replaces.empty() ? "" : " in place of " + out.hypotheses[1].replaces) + ", DYN cost " +
                       fmt4(out.hypotheses[1].dyn_cost) + "): both reported";
    } else if (out.hypotheses.size() >= 2) {
        out.verdict += "; told apart from " + out.hypotheses[1].text + " (DYN cost " + fmt4(out.hypotheses[1].dyn_cost) + ")";
    }
    out.verdict += "; FDJ " + fmt4(out.fdj_before_nm) + " -> " + fmt4(best.fdj_nm) + " N m)";
}

}  // namespace

BreakawayAcross breakaway_across(const Run& brk, const std::string& brk_label, const Run& dyn,
                                 const std::string& dyn_label, const DiscoveryReport& dyn_report) {
    BreakawayAcross out;
    out.brk_label = brk_label;
    out.dyn_label = dyn_label;
    sim::EmaParams p = dyn_report.model.params;
    const std::optional<Thresholds> meas = measured_thresholds(brk, p, out);
    if (!meas) return out;
    std::string why;
    // 2. The DYN model on the BRK sequence (FSJ from the BRK run: the thresholds' mean; the
    // asymmetry does not depend on it), and the probes, in one batch.
    out.fsj_nm = std::max(p.fdj_nm, 0.5 * (meas->up + meas->down));
    std::erase_if(p.terms, [](const sim::Term& t) { return t.target != sim::TermTarget::Torque; });
    p.effects.current_gain_error = 0;
    p.effects.hinge_offset_nm = 0;
    p.fsj_nm = out.fsj_nm;
    std::vector<sim::EmaParams> batch = {p};
    for (const auto& pr : kProbes) {
        sim::EmaParams q = p;
        q.terms.push_back(constant_term(pr.target, pr.size));
        batch.push_back(q);
    }
    // The DYN model's torque terms that act at rest (no factor of the speed): an offset at rest may
    // be one of them misnamed (seed 163901: a constant torque of 0.0055 N m named "torque ~ t" by the
    // DYN run, whose trajectory preferred it, 2.16 against 2.92, fitted on the torque residual). The
    // candidates are also tried in their place, sized against the model without them.
    std::vector<sim::Term> rest_terms;
    std::copy_if(p.terms.begin(), p.terms.end(), std::back_inserter(rest_terms), acts_at_rest);
    if (!rest_terms.empty()) {
        sim::EmaParams bare = p;
        std::erase_if(bare.terms, acts_at_rest);
        batch.push_back(bare);
    }
    const std::vector<Run> sims = resimulate_many(brk, batch);
    const std::optional<Thresholds> model = thresholds(sims[0], why);
    if (!model) {
        out.problem = "the model re-simulated on the BRK sequence: " + why;
        out.verdict = "not compared: " + out.problem;
        return out;
    }
    out.up_model_nm = model->up;
    out.down_model_nm = model->down;
    // The analysis of the model's own, noise-free BRK run must give back the FSJ the model was
    // given (to the chatter's fraction of a step), or the two are not comparable.
    if (std::abs(0.5 * (model->up + model->down) - out.fsj_nm) > kBrkModelFsjTolerance * out.fsj_nm) {
        out.problem = "the breakaway analysis of the model's BRK run gives thresholds " + fmt4(model->up) + " and " +
                      fmt4(model->down) + " N m for an FSJ of " + fmt4(out.fsj_nm) + " N m";
        out.verdict = "not compared: " + out.problem;
        return out;
    }
    // 3. The asymmetry beyond the model.
    out.asymmetry_nm = 0.5 * ((meas->up - model->up) - (meas->down - model->down));
    out.z = out.asymmetry_se_nm > 0 ? out.asymmetry_nm / out.asymmetry_se_nm : 0.0;
    out.significant = std::abs(out.z) >= kBrkAsymmetryMinZ;
    const std::string measured = "BRK thresholds S+ " + fmt4(meas->up) + " +/- " + fmt4(meas->up_se) + ", S- " +
                                 fmt4(meas->down) + " +/- " + fmt4(meas->down_se) + " N m against the model's " +
                                 fmt4(model->up) + " and " + fmt4(model->down) + ": asymmetry " + fmt4(out.asymmetry_nm) +
                                 " +/- " + fmt4(out.asymmetry_se_nm) + " N m (z = " + fmt4(out.z) + ")" +
                                 (out.sensor_correction.empty() ? std::string()
                                                                : ", with the DYN model's sensor errors (" + out.sensor_correction +
                                                                      ") removed from the BRK run (" + out.as_recorded + ")");
    if (!out.significant) {
        const auto found = dyn_report.added_effects();
        std::string with;
        for (const auto& f : found) with += (with.empty() ? "" : ", ") + f;
        out.verdict = "the BRK run agrees with the DYN run's model" + (with.empty() ? std::string() : " (with " + with + ")") +
                      ": " + measured;
        return out;
    }
    // 4. The constant terms that can explain it, sized by it (and, in place of the DYN model's terms
    // that act at rest, by the asymmetry beyond the model without them).
    size_hypotheses(out, *meas, *model, sims, rest_terms);
    if (out.hypotheses.empty()) {
        out.verdict = "UNEXPLAINED at rest: " + measured + "; no constant torque, hinge-moment, current or angle offset moves the BRK thresholds that way";
        return out;
    }
    refit_on_dyn(out, dyn, dyn_report);
    name_best(out, measured);
    return out;
}

nlohmann::json BreakawayAcross::to_json() const {
    nlohmann::json j = {{"brk_run", brk_label}, {"dyn_run", dyn_label}, {"verdict", verdict}};
    if (!problem.empty()) {
        j["problem"] = problem;
        return j;
    }
    j["thresholds_Nm"] = {{"up", up_nm}, {"up_se", up_se_nm}, {"down", down_nm}, {"down_se", down_se_nm},
                          {"up_model", up_model_nm}, {"down_model", down_model_nm}, {"fsj_model", fsj_nm}};
    if (!sensor_correction.empty()) j["sensor_correction"] = {{"removed", sensor_correction}, {"as_recorded", as_recorded}};
    j["asymmetry_Nm"] = asymmetry_nm;
    j["asymmetry_se_Nm"] = asymmetry_se_nm;
    j["z"] = z;
    j["significant"] = significant;
    j["dyn_trajectory_cost_before"] = dyn_cost_before;
    j["dyn_trajectory_cost_model_refit"] = dyn_cost_model;
    j["fdj_before_Nm"] = fdj_before_nm;
    j["hypotheses"] = nlohmann::json::array();
    for (const auto& h : hypotheses) {
        j["hypotheses"].push_back({{"name", h.key}, {"physics", h.text}, {"term", sim::to_json(h.term)},
                                   {"asymmetry_per_unit_Nm", h.asymmetry_per_unit}, {"dyn_trajectory_cost", h.dyn_cost},
                                   {"fdj_Nm", h.fdj_nm}, {"fdj_se_Nm", h.fdj_se_nm}, {"replaces", h.replaces}});
    }
    j["hypotheses_equivalent"] = equivalent;
    j["finding"] = nullptr;
    if (!terms.empty()) {
        nlohmann::json t = nlohmann::json::array();
        for (const auto& x : terms) t.push_back(sim::to_json(x));
        j["finding"] = {{"name", key}, {"physics", text}, {"terms", t}};
    }
    return j;
}

}  // namespace emadiag::discovery
