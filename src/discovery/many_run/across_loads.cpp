#include "discovery/many_run/across_loads.hpp"

#include "discovery/model/fit_parameter.hpp"
#include "discovery/physics_names.hpp"
#include "discovery/screening/screen_windows.hpp"
#include "discovery/model/resimulation.hpp"
#include "discovery/screening/effect_screen.hpp"
#include "discovery/model/run_signals.hpp"
#include "discovery/screening/term_library.hpp"
#include "estimation/health_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <set>

namespace emadiag::discovery {
namespace {

/// Iterations of each per-run fit (they start next to the optimum: the run's own model).
constexpr int kLoadFitIterations = 6;
/// The chi-square's upper point for "consistent" (Wilson-Hilferty at 99.9 %: z = 3.09).
double chi2_upper(std::size_t dof) {
    const double k = static_cast<double>(dof);
    const double a = 2.0 / (9.0 * k);
    return k * std::pow(1.0 - a + 3.09 * std::sqrt(a), 3);
}

/// A run's model without any term of the hypotheses' shapes (its efficiency stage's friction, or the
/// same friction found by its screening): each hypothesis is judged alone, and puts its term back
/// with the pooled coefficient.
sim::EmaParams base_model(const DiscoveryReport& r, const std::set<std::string>& shapes) {
    sim::EmaParams p = r.model.params;
    std::erase_if(p.terms, [&](const sim::Term& x) { return x.target == sim::TermTarget::Torque && shapes.contains(x.basis_text()); });
    return p;
}

bool eta_identified(const DiscoveryReport& r) {
    for (const auto& h : r.baseline_health) {
        if (h.name == kParamEtaO) return h.source == "estimated";
    }
    return false;
}

/// Where a term's fit starts on a run: the coefficient the run's efficiency stage found for the same
/// basis, or the least-squares one on the torque residual of the run's model at the datasheet eta_O,
/// with the FDJ column (the fit's finite-difference step is relative: it cannot start at 0).
double term_start(const sim::Term& shape, const Run& run, const DiscoveryReport& r, const std::set<std::string>& shapes,
                  const RunSignals& s, const std::vector<char>& mask) {
    for (const auto& t : r.efficiency.terms) {
        if (t.target == shape.target && t.basis_text() == shape.basis_text()) return t.coefficient;
    }
    sim::EmaParams p = base_model(r, shapes);
    p.eta_o = sim::EmaParams::datasheet().eta_o;
    p.eta_a = sim::eta_a_from_eta_o(p.eta_o, p.tau);
    const RunSignals m = resimulate_signals(resim_target(run), p);
    const std::vector<double> f = sensitivity(run, p, m, FitParameter::fdj());
    sim::Term unit = shape;
    unit.coefficient = 1.0;
    const std::vector<double> x = term_signature(s, unit);
    // Two columns, normal equations.
    double ff = 0, fx = 0, xx = 0, fr = 0, xr = 0;
    for (std::size_t k = 0; k < s.size(); ++k) {
        if (!mask[k]) continue;
        const double res = s.residual_torque_nm[k] - m.residual_torque_nm[k];
        ff += f[k] * f[k];
        fx += f[k] * x[k];
        xx += x[k] * x[k];
        fr += f[k] * res;
        xr += x[k] * res;
    }
    const double det = ff * xx - fx * fx;
    if (!(det > 0)) return 0.0;
    return (ff * xr - fx * fr) / det;
}

/// What the load hypotheses are judged on: the runs with their reports, signals and comparison
/// masks, and the bases of the hypotheses' shapes (base_model takes them out of each run's model).
struct LoadRuns {
    const std::vector<const Run*>& runs;
    const std::vector<DiscoveryReport>& reports;
    const std::vector<RunSignals>& signals;
    const std::vector<std::vector<char>>& masks;
    const std::set<std::string>& seen;
};

/// One hypothesis (`shape`, or nullopt: the efficiency) judged: 1. free on each run that identifies it,
/// pooled; 2. the pooled value on every run, FDJ refitted. Nullopt when no run identifies it.
std::optional<LoadHypothesis> judge_hypothesis(const std::optional<sim::Term>& shape, const LoadRuns& lr) {
    const std::vector<const Run*>& runs = lr.runs;
    const std::vector<DiscoveryReport>& reports = lr.reports;
    const std::vector<RunSignals>& signals = lr.signals;
    const std::vector<std::vector<char>>& masks = lr.masks;
    const std::set<std::string>& seen = lr.seen;
    const double eta_ds = sim::EmaParams::datasheet().eta_o;
    LoadHypothesis h;
    if (shape) {
        const PhysicsName n = physics_name(*shape);
        h.key = n.key;
        h.text = n.text;
        h.parameter = shape->basis_text();
    } else {
        h.key = "efficiency";
        h.text = "eta_O off the datasheet (one efficiency for every run)";
        h.parameter = "eta_O";
    }
    // The start of run i under this hypothesis, and the name of its parameter.
    auto start_of = [&](std::size_t i, double value) {
        sim::EmaParams p = base_model(reports[i], seen);
        if (shape) {
            p.eta_o = eta_ds;
            sim::Term t = *shape;
            t.coefficient = value;
            p.terms.push_back(t);
        } else {
            p.eta_o = value;
        }
        p.eta_a = sim::eta_a_from_eta_o(p.eta_o, p.tau);
        return p;
    };
    // Fitted on the torque residual (window sums over the comparison samples, as the single run's
    // efficiency stage does: its standard errors are those of nearly independent rows), judged on
    // the trajectory.
    auto fit = [&](std::size_t i, const sim::EmaParams& start, const std::vector<FitParameter>& names) {
        return fit_by_resimulation(*runs[i], signals[i], start, names, masks[i], start.fsj_nm, kFitWindowSamples, nullptr,
                                   kLoadFitIterations);
    };
    // 1. Free on each run that identifies it.
    double sw = 0, swv = 0;
    for (std::size_t i = 0; i < runs.size(); ++i) {
        double v = std::numeric_limits<double>::quiet_NaN(), se = v;
        const bool free = shape ? true : eta_identified(reports[i]);
        if (free) {
            const double v0 = shape ? term_start(*shape, *runs[i], reports[i], seen, signals[i], masks[i])
                                    : (reports[i].efficiency.ran ? reports[i].efficiency.eta_o : base_model(reports[i], seen).eta_o);
            const sim::EmaParams start = start_of(i, v0);
            const FitParameter name = shape ? FitParameter::term(start.terms.size() - 1) : FitParameter::eta_o();
            const FitResult f = fit(i, start, {FitParameter::fdj(), name});
            for (const auto& fv : f.values) {
                if (fv.parameter == name) {
                    v = fv.value;
                    se = fv.std_error;
                }
            }
            if (std::isfinite(v) && se > 0) {
                sw += 1.0 / (se * se);
                swv += v / (se * se);
            }
        }
        h.values.push_back(v);
        h.std_errors.push_back(se);
    }
    if (sw <= 0) return std::nullopt;  // no run identifies it
    h.pooled = swv / sw;
    h.pooled_se = std::sqrt(1.0 / sw);
    for (std::size_t i = 0; i < runs.size(); ++i) {
        if (std::isfinite(h.values[i]) && h.std_errors[i] > 0) {
            h.chi2 += std::pow((h.values[i] - h.pooled) / h.std_errors[i], 2);
            ++h.dof;
        }
    }
    h.dof = h.dof > 0 ? h.dof - 1 : 0;
    h.consistent = h.dof == 0 || h.chi2 <= chi2_upper(h.dof);
    // 2. The pooled value on every run, FDJ refitted.
    double sum = 0;
    for (std::size_t i = 0; i < runs.size(); ++i) {
        const FitResult f = fit(i, start_of(i, h.pooled), {FitParameter::fdj()});
        h.costs.push_back(trajectory_error(signals[i], f.signals, reports[i].floor).cost);
        sum += h.costs.back();
    }
    h.mean_cost = sum / static_cast<double>(runs.size());
    return h;
}

}  // namespace

AcrossLoads across_loads(const std::vector<const Run*>& runs, const std::vector<std::string>& labels,
                         const std::vector<DiscoveryReport>& reports) {
    AcrossLoads out;
    out.labels = labels;
    std::set<std::string> cases;
    bool efficiency_ran = false;
    for (const auto* r : runs) {
        out.load_cases.push_back(sim::to_string(r->load_case));
        cases.insert(out.load_cases.back());
    }
    for (const auto& r : reports) efficiency_ran = efficiency_ran || r.efficiency.ran;
    if (cases.size() < 2) {
        out.skipped = "the runs are of one load case";
        return out;
    }
    if (!efficiency_ran) {
        out.skipped = "no run's eta_O is off the datasheet value (nothing for the load cases to tell apart)";
        return out;
    }
    out.ran = true;
    // The hypotheses: the efficiency, each single-term friction a run's efficiency stage found, and
    // the two that load and deflection stand for: friction ~ sgn(w) |F_R| and ~ sgn(w) |theta_u|.
    std::vector<std::optional<sim::Term>> shapes = {std::nullopt};  // nullopt: the efficiency
    std::set<std::string> seen;
    auto add_shape = [&](sim::Term t) {
        t.coefficient = 0;
        t.std_error = 0;
        if (seen.insert(t.basis_text()).second) shapes.emplace_back(t);
    };
    for (const auto& r : reports) {
        if (r.efficiency.ran && r.efficiency.terms.size() == 1) add_shape(r.efficiency.terms.front());
    }
    add_shape(sim::parse_term("torque: 0*sgn(w)*abs(F_R)"));
    add_shape(sim::parse_term("torque: 0*sgn(w)*abs(theta_u)"));
    std::vector<RunSignals> signals;
    std::vector<std::vector<char>> masks;
    for (std::size_t i = 0; i < runs.size(); ++i) {
        signals.push_back(run_signals(*runs[i]));
        masks.push_back(comparison_mask(signals[i], resimulate_signals(resim_target(*runs[i]), base_model(reports[i], seen))));
    }
    const LoadRuns lr{runs, reports, signals, masks, seen};
    for (const auto& shape : shapes) {
        if (auto h = judge_hypothesis(shape, lr)) out.hypotheses.push_back(std::move(*h));
    }
    // Ranked by the mean cost at the pooled value, which is what one actuator must satisfy; the
    // chi-square of the per-run values is reported beside it.
    std::stable_sort(out.hypotheses.begin(), out.hypotheses.end(),
                     [](const LoadHypothesis& a, const LoadHypothesis& b) { return a.mean_cost < b.mean_cost; });
    auto describe = [&](const LoadHypothesis& h) {
        std::string s = h.text + ": " + h.parameter + " " + fmt4(h.pooled) + " +/- " + fmt4(h.pooled_se) + ", mean trajectory cost " +
                        fmt4(h.mean_cost) + " (";
        for (std::size_t i = 0; i < h.costs.size(); ++i) s += (i ? ", " : "") + out.load_cases[i] + " " + fmt4(h.costs[i]);
        s += ")";
        if (!h.consistent) s += ", the runs disagree on it (chi2 " + fmt4(h.chi2) + " on " + std::to_string(h.dof) + " dof)";
        return s;
    };
    if (out.hypotheses.empty()) {
        out.verdict = "no statement holds on every load case";
        for (const auto& h : out.hypotheses) out.verdict += "; " + describe(h);
        return out;
    }
    const LoadHypothesis& best = out.hypotheses.front();
    out.key = best.key;
    out.text = best.text;
    if (best.key != "efficiency") {
        for (const auto& shape : shapes) {
            if (shape && shape->basis_text() == best.parameter) {
                sim::Term t = *shape;
                t.coefficient = best.pooled;
                t.std_error = best.pooled_se;
                out.terms.push_back(t);
            }
        }
    }
    out.equivalent = out.hypotheses.size() >= 2 &&
                     not_told_apart(best.mean_cost, out.hypotheses[1].mean_cost, kHypothesisRatio);
    out.verdict = (out.equivalent ? "NOT told apart by the load cases: " : "the load cases tell: ") + describe(best);
    for (std::size_t k = 1; k < out.hypotheses.size(); ++k) {
        out.verdict += (k == 1 && out.equivalent ? "; or equally " : k == 1 ? "; against " : "; ") + describe(out.hypotheses[k]);
    }
    return out;
}

nlohmann::json AcrossLoads::to_json() const {
    nlohmann::json j = {{"ran", ran}};
    if (!ran) {
        j["skipped"] = skipped;
        return j;
    }
    j["load_cases"] = load_cases;
    j["verdict"] = verdict;
    j["hypotheses"] = nlohmann::json::array();
    for (const auto& h : hypotheses) {
        nlohmann::json values = nlohmann::json::array(), ses = nlohmann::json::array();
        for (std::size_t i = 0; i < h.values.size(); ++i) {
            values.push_back(std::isfinite(h.values[i]) ? nlohmann::json(h.values[i]) : nlohmann::json(nullptr));
            ses.push_back(std::isfinite(h.std_errors[i]) ? nlohmann::json(h.std_errors[i]) : nlohmann::json(nullptr));
        }
        j["hypotheses"].push_back({{"name", h.key}, {"physics", h.text}, {"parameter", h.parameter}, {"per_run", values},
                                   {"per_run_se", ses}, {"pooled", h.pooled}, {"pooled_se", h.pooled_se}, {"chi2", h.chi2},
                                   {"dof", h.dof}, {"consistent", h.consistent}, {"trajectory_costs", h.costs},
                                   {"mean_trajectory_cost", h.mean_cost}});
    }
    j["equivalent"] = equivalent;
    j["finding"] = key.empty() ? nlohmann::json(nullptr) : nlohmann::json({{"name", key}, {"physics", text}});
    if (!terms.empty()) {
        nlohmann::json t = nlohmann::json::array();
        for (const auto& x : terms) t.push_back(sim::to_json(x));
        j["finding"]["terms"] = t;
    }
    return j;
}

}  // namespace emadiag::discovery
