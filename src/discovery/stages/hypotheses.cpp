// The hypotheses of a torque round: the alternatives of the winner, fitted by re-simulation and
// told apart by the trajectory (hypotheses.hpp).
#include "discovery/stages/hypotheses.hpp"

#include "discovery/fits/fits.hpp"
#include "discovery/physics_names.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace emadiag::discovery::pipeline {
namespace {

/// A torque periodic in one angle and its twin in the other at the equivalent period differ only by
/// the transmission's compliance and backlash between the angles. The trajectory does not tell them
/// apart reliably (seed 97's torque periodic in theta_m: the theta_u twin's trajectory cost 2.64
/// against the truth's 5.87), while the torque screening did (delta BIC 429 against 92): the twin never
/// replaces the screening's choice and is always reported beside it as equivalent.
constexpr double kPeriodicTwinRatio = std::numeric_limits<double>::infinity();
/// The hypotheses' refit on the trajectory (refit_close_hypotheses_on_trajectory): the best two
/// above this cost and within this ratio of each other.
constexpr double kHypothesisRefitAboveCost = 1.5;
constexpr double kHypothesisRefitRatio = 2.0;
/// Factors of a library effect's hypothesis: it has none to compare (parsimony).
constexpr std::size_t kNoDegree = std::numeric_limits<std::size_t>::max();

/// An explanation that leaves the same signature in the torque residual as the one found.
struct Alternative {
    std::string key, text;
    std::vector<sim::Term> terms;  ///< added to the model without the effect found (start values of its fit)
    /// Cost ratio by which the trajectory tells this explanation and the one found apart.
    double tell_apart_ratio = kHypothesisRatio;
};

/// The same periodicity in the other angle: a period in theta_u (deg) as one in theta_m (rad), and
/// back (theta_m = tau theta_u).
double equivalent_period(const sim::TermFactor& f, double tau) {
    constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
    return f.signal == sim::TermSignal::ThetaSurface ? f.a * tau * kDegToRad : f.a / (tau * kDegToRad);
}

/// The alternatives of a step's explanation (docs/discovery.md "Hypotheses"):
///   constant in T_R:  hinge-moment sensor offset | constant torque | current sensor offset
///   k_t I in T_R:     current sensor gain        | a real torque ~ I (motor torque constant)
///   dw/dt in T_R:     inertia                    | speed sensor gain
///   F_R in T_R:       a real torque ~ F_R        | hinge-moment sensor gain
///   periodic term:    the same periodicity in the other angle (the twin; always equivalent)
std::vector<Alternative> alternatives(const DiscoveryStep& step, const sim::EmaParams& fitted, double j_kgm2,
                                      const RunSignals& s) {
    using sim::TermBasis;
    using sim::TermSignal;
    using sim::TermTarget;
    std::vector<Alternative> out;
    auto add = [&](const sim::Term& t) {
        const PhysicsName n = physics_name(t);
        out.push_back({n.key, n.text, {t}});
    };
    if (step.added) {
        switch (step.added->kind) {
            case EffectKind::HingeOffset: {
                const double c = -fitted.effects.hinge_offset_nm / s.tau;  // T_R shift, N m
                add(make_term(TermTarget::Torque, c, {}));
                add(make_term(TermTarget::Current, c / s.k_t_nm_per_a, {}));
                break;
            }
            case EffectKind::CurrentGain: {
                const double e = fitted.effects.current_gain_error;
                add(make_term(TermTarget::Torque, s.k_t_nm_per_a * e / (1.0 + e),
                              {{TermBasis::Identity, TermSignal::Current, 0, 0}}));
                break;
            }
            case EffectKind::Inertia: {
                const double a = fitted.effects.true_inertia_kgm2 - j_kgm2;
                add(make_term(TermTarget::Speed, -a / j_kgm2, {{TermBasis::Identity, TermSignal::Speed, 0, 0}}));
                break;
            }
            default: break;
        }
    } else if (step.added_terms.size() == 1 && step.name_key == "load_torque_gain") {
        add(make_term(TermTarget::Hinge, -step.added_terms.front().coefficient * s.tau,
                      {{TermBasis::Identity, TermSignal::LoadTorque, 0, 0}}));
    } else if (!step.added_terms.empty() && period_factor(step.added_terms.front()) != nullptr) {
        // A torque periodic in one angle is periodic in the other at the equivalent period
        // (theta_m = tau theta_u): only the transmission's compliance and backlash between the two
        // angles can tell them apart, so the trajectory decides, and may leave them equivalent.
        std::vector<sim::Term> other = step.added_terms;
        for (auto& t : other) {
            for (auto& f : t.factors) {
                if (!is_period_basis(f)) continue;
                f.a = equivalent_period(f, s.tau);
                f.signal = f.signal == TermSignal::ThetaSurface ? TermSignal::ThetaMotor : TermSignal::ThetaSurface;
            }
        }
        const PhysicsName n = physics_name(other.front());
        out.push_back({n.key, n.text, other, kPeriodicTwinRatio});
    }
    return out;
}

/// Hypotheses are fitted on the torque residual and judged on the trajectory, which can be far more
/// sensitive (a constant torque of 0.0055 N m moves the angle by 30 noise floors): a torque fit a
/// little off costs several floors there. When the best two of different names are both above
/// kHypothesisRefitAboveCost and within kHypothesisRefitRatio of each other, each is refitted on the
/// trajectory (the health and its own parameters, kFinalRefitIterations) and judged by that cost.
/// The model keeps the torque fit (the final refit on the trajectory comes later). Seed 163901: a
/// constant torque of 0.0055 N m lost to "torque ~ t", 2.92 against 2.16, fitted on the torque.
template <class FitOf, class EffectOf, class TermsOf>
void refit_close_hypotheses_on_trajectory(const Context& ctx, DiscoveryStep& st, const FitOf& fit_of, const EffectOf& effect_of,
                                          const TermsOf& terms_of) {
    const RunSignals& s = ctx.signals;
    const NoiseFloor& floor = ctx.floor;
    const double fsj_base_nm = ctx.fsj_base_nm;
    const std::vector<FitParameter>& health_parameters = ctx.health_parameters;
    if (st.hypotheses.size() < 2) return;
    std::vector<std::size_t> order(st.hypotheses.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return st.hypotheses[a].cost < st.hypotheses[b].cost; });
    const std::size_t a = order[0];
    std::size_t b = order.size();
    // A hypothesis with a wider margin to be told apart (the periodic twin) never replaces the
    // choice on a close cost: no refit for it.
    for (std::size_t k = 1; k < order.size(); ++k) {
        if (st.hypotheses[order[k]].key != st.hypotheses[a].key && st.hypotheses[order[k]].tell_apart_ratio <= kHypothesisRatio &&
            st.hypotheses[a].tell_apart_ratio <= kHypothesisRatio) {
            b = order[k];
            break;
        }
    }
    if (b == order.size()) return;
    const double lo = st.hypotheses[a].cost, hi = st.hypotheses[b].cost;
    if (!(lo > kHypothesisRefitAboveCost && hi < kHypothesisRefitRatio * lo)) return;
    for (std::size_t i : {a, b}) {
        const FitResult& f = fit_of(i);
        std::vector<FitParameter> names = health_parameters;
        if (const std::optional<EffectShape> e = effect_of(i)) {
            for (const FittedEffect n : fitted_sim_effects(e->kind)) names.push_back(FitParameter::effect(n));
        }
        const std::size_t n_terms = terms_of(i);
        for (std::size_t k = f.params.terms.size() - n_terms; k < f.params.terms.size(); ++k) names.push_back(FitParameter::term(k));
        try {
            const FitResult r = fit_by_resimulation(ctx.run, s, f.params, names, ctx.mask, fsj_base_nm, kFitWindowSamples, nullptr,
                                                    kFinalRefitIterations, &floor);
            const TrajectoryError te = trajectory_error(s, r.signals, floor);
            st.simulations += r.simulations;
            if (te.cost < st.hypotheses[i].cost) {
                st.hypotheses[i].cost = te.cost;
                st.hypotheses[i].error = te;
                st.hypotheses[i].refit_on_trajectory = true;
            }
        } catch (const std::exception&) {
            // Keeps its torque-fit cost.
        }
    }
}

/// A fitted alternative: its fit, re-simulation, and what it adds to the model before the round.
struct AltFit {
    FitResult fit;
    RunSignals sim;
    std::size_t terms = 0;  // the alternative's terms, last in the fit's model
    std::optional<EffectShape> effect;  // or the library effect it adds
};

struct HypothesisFits {
    std::vector<std::size_t> degrees;  ///< factors of each hypothesis' terms (kNoDegree: a library effect)
    std::vector<AltFit> alt_fits;      ///< hypothesis i + 1's fit
    bool library_rival = false;        ///< the library effect that lost the screening is hypothesis 1
};

/// The round's winner as the first hypothesis, then the library rival and the alternatives, each
/// fitted by re-simulation from `p_prev` (a hypothesis that cannot be simulated or fails the
/// criterion is dropped, with a note).
HypothesisFits fit_hypotheses(Context& ctx, DiscoveryStep& step, const RoundFit& rf, const sim::EmaParams& p_prev,
                              const std::vector<Alternative>& alts, bool with_library_rival, const CandidateEvidence* lib_best) {
    const RunSignals& s = ctx.signals;
    const NoiseFloor& floor = ctx.floor;
    DiscoveryReport& rep = ctx.rep;
    const FitResult& fit = rf.fit;
    const TrajectoryError& traj_new = rf.traj_new;
    const std::string& amp_text = rf.amp_text;
    HypothesisFits hf;
    hf.library_rival = with_library_rival;
    bool& library_rival = hf.library_rival;
    Hypothesis h0{step.name_key, step.name_text, amp_text, traj_new.cost, traj_new, fit.simulations};
    step.hypotheses.push_back(h0);
    // Factors of each hypothesis' terms (parsimony below); a library effect has none to compare.
    std::vector<std::size_t>& degrees = hf.degrees;
    degrees = {step.added ? kNoDegree : term_degree(step.added_terms)};
    std::vector<AltFit>& alt_fits = hf.alt_fits;
    if (library_rival) {
        LibraryFit lf = fit_library(ctx, *lib_best);
        const std::string key = effect_name(lf.shape.kind);
        if (lf.bic > kMinDeltaBic && lf.peak >= kMinEffectPeakNm) {
            const TrajectoryError te = trajectory_error(s, lf.fit.signals, floor);
            step.hypotheses.push_back({key, library_effect_text(lf.shape.kind), lf.amp_text, te.cost, te, lf.fit.simulations});
            degrees.push_back(kNoDegree);
            step.simulations += lf.fit.simulations;
            AltFit af;
            af.sim = lf.fit.signals;
            af.fit = std::move(lf.fit);
            af.effect = lf.shape;
            alt_fits.push_back(std::move(af));
        } else {
            library_rival = false;
            rep.notes.push_back("hypothesis " + key + " dropped: its re-simulation fit gives " + lf.amp_text + ", delta BIC " +
                                std::to_string(lf.bic) + ", peak torque " + std::to_string(lf.peak) + " N m");
        }
    }
    for (const auto& alt : alts) {
        AltFit af;
        af.terms = alt.terms.size();
        try {
            af.fit = fit_terms(ctx, p_prev, alt.terms, kHypothesisFitIterations);
            af.sim = af.fit.signals;
        } catch (const std::exception& e) {  // the alternative cannot be simulated: it is not a hypothesis
            rep.notes.push_back("hypothesis " + alt.key + " (" + alt.terms.front().text() + ") dropped: " + e.what());
            continue;
        }
        const TrajectoryError te = trajectory_error(s, af.sim, floor);
        std::string change;
        for (auto t = af.fit.params.terms.end() - static_cast<std::ptrdiff_t>(af.terms); t != af.fit.params.terms.end(); ++t) {
            change += (change.empty() ? "" : ", ") + t->text();
        }
        step.hypotheses.push_back({alt.key, alt.text, change, te.cost, te, af.fit.simulations, alt.tell_apart_ratio});
        degrees.push_back(term_degree(alt.terms));
        step.simulations += af.fit.simulations;
        alt_fits.push_back(std::move(af));
    }
    return hf;
}

/// The hypothesis the trajectory favours (with the margins and the parsimony below) replaces the
/// winner; the hypotheses are ordered, the chosen first, and told equivalent or not.
void choose_hypothesis(Context& ctx, DiscoveryStep& step, RoundFit& rf, const HypothesisFits& hf, std::size_t model_terms_before) {
    DiscoveryReport& rep = ctx.rep;
    FitResult& fit = rf.fit;
    sim::EmaParams& p_new = rf.p_new;
    RunSignals& new_sim = rf.new_sim;
    TrajectoryError& traj_new = rf.traj_new;
    const std::vector<std::size_t>& degrees = hf.degrees;
    const std::vector<AltFit>& alt_fits = hf.alt_fits;
    const bool library_rival = hf.library_rival;
    refit_close_hypotheses_on_trajectory(ctx, step, [&](std::size_t i) -> const FitResult& { return i == 0 ? fit : alt_fits[i - 1].fit; },
                                         [&](std::size_t i) -> std::optional<EffectShape> { return i == 0 ? step.added : alt_fits[i - 1].effect; },
                                         [&](std::size_t i) { return i == 0 ? step.added_terms.size() : alt_fits[i - 1].terms; });
    std::size_t best = 0;
    for (std::size_t i = 1; i < step.hypotheses.size(); ++i) {
        if (step.hypotheses[i].cost < step.hypotheses[best].cost) best = i;
    }
    // An explanation that needs a wider margin than kHypothesisRatio to be told apart (the
    // periodic twin) replaces the first (the screening's choice) only beyond that margin; so does
    // the library effect that lost the screening to generated terms (where the trajectory cannot
    // tell them apart, the screening's choice stays first and the other is reported as equivalent).
    if (best != 0) {
        const Hypothesis& b = step.hypotheses[best];
        const bool margin = b.tell_apart_ratio > kHypothesisRatio || (library_rival && best == 1);
        if (margin && !(b.tell_apart_ratio * b.cost < step.hypotheses[0].cost)) best = 0;
    }
    // Parsimony: of the term hypotheses the trajectory does not tell from the best (kHypothesisRatio,
    // kHypothesisMinCostGap), the one with the fewest factors (seed 131: a constant torque of
    // 0.039 N m and a torque ~ t, costs 4.67 and 4.62; the t term took FDJ to 0.042 N m).
    if (degrees[best] != kNoDegree) {
        const std::size_t b0 = best;
        for (std::size_t i = 0; i < step.hypotheses.size(); ++i) {
            const Hypothesis& h = step.hypotheses[i];
            if (degrees[i] >= degrees[best] || h.tell_apart_ratio > kHypothesisRatio) continue;
            if (not_told_apart(h.cost, step.hypotheses[b0].cost, kHypothesisRatio)) best = i;
        }
    }
    if (best != 0) {
        // An alternative explains the trajectory better: it replaces the first explanation.
        const AltFit& af = alt_fits[best - 1];
        fit = af.fit;
        p_new = af.fit.params;
        new_sim = af.sim;
        traj_new = step.hypotheses[best].error;
        if (step.added) ctx.excluded.push_back(step.added->kind);
        step.added = af.effect;
        step.added_terms.assign(p_new.terms.end() - static_cast<std::ptrdiff_t>(af.terms), p_new.terms.end());
        step.name_key = step.hypotheses[best].key;
        step.name_text = step.hypotheses[best].text;
        step.fitted = fit.values;
        rep.model.terms.resize(model_terms_before);
    }
    // The explanation chosen first, then the others by trajectory cost.
    const Hypothesis chosen = step.hypotheses[best];
    step.hypotheses.erase(step.hypotheses.begin() + static_cast<std::ptrdiff_t>(best));
    std::stable_sort(step.hypotheses.begin(), step.hypotheses.end(),
                     [](const Hypothesis& a, const Hypothesis& b) { return a.cost < b.cost; });
    step.hypotheses.insert(step.hypotheses.begin(), chosen);
    if (step.hypotheses.size() >= 2) {
        const Hypothesis &h1 = step.hypotheses[0], &h2 = step.hypotheses[1];
        step.equivalent = not_told_apart(h1.cost, h2.cost, std::max(h1.tell_apart_ratio, h2.tell_apart_ratio));
    }
}

}  // namespace

void drop_same_periodicity(std::vector<TermFamily>& lib, const std::vector<sim::TermFactor>& taken, double tau) {
    for (auto& fam : lib) {
        std::erase_if(fam.shapes, [&](const std::vector<sim::Term>& block) {
            const sim::TermFactor* f = block.empty() ? nullptr : period_factor(block.front());
            if (f == nullptr) return false;
            return std::any_of(taken.begin(), taken.end(), [&](const sim::TermFactor& t) {
                if (t.signal == f->signal) return false;
                const double ratio = f->a / equivalent_period(t, tau);
                return ratio < kPeriodRefineSpan && ratio > 1.0 / kPeriodRefineSpan;
            });
        });
    }
    std::erase_if(lib, [](const TermFamily& fam) { return fam.shapes.empty(); });
}

void weigh_hypotheses(Context& ctx, DiscoveryStep& step, RoundFit& rf, const sim::EmaParams& p_prev, std::size_t model_terms_before,
                      const CandidateEvidence* lib_best, const GenericEvidence* gen_rival) {
    // Hypotheses the torque residual cannot tell apart: fit each alternative by re-simulation and
    // compare the trajectories.
    std::vector<Alternative> alts = alternatives(step, rf.p_new, p_prev.j_kgm2, ctx.signals);
    // A library effect chosen over generated terms that pass the BIC: the generated terms are a
    // hypothesis too (a library effect can mimic them on the torque residual, e.g. viscous
    // friction and friction ~ w^2 at the plateau speed); the trajectory decides.
    if (step.added && gen_rival != nullptr && gen_rival->terms.size() == 1) {
        const PhysicsName n = physics_name(gen_rival->terms.front());
        if (n.key != step.name_key) alts.push_back({n.key, n.text, {gen_rival->terms.front()}, kHypothesisRatio});
    }
    // Generated terms chosen over a library effect that passes the criterion: the library effect is a
    // hypothesis too (seed 113's spall: delta BIC 36.5 against 36.7 for friction ~ sgn(w) theta_u F_R,
    // which then pulled eta_O to 0.93); the trajectory decides.
    bool library_rival = !step.added && lib_best != nullptr;
    if (!alts.empty() || library_rival) {
        const HypothesisFits hf = fit_hypotheses(ctx, step, rf, p_prev, alts, library_rival, lib_best);
        choose_hypothesis(ctx, step, rf, hf, model_terms_before);
    }
}

}  // namespace emadiag::discovery::pipeline
