// GCC 12 reports false -Wmaybe-uninitialized inside Eigen's AVX-512 kernels (matrix-vector product).
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#include "discovery/resimulation.hpp"

#include "core/emadiag_error.hpp"
#include "core/sim_run.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <thread>
#include <utility>

namespace emadiag::discovery {
namespace {

/// Range and finite-difference step of each fittable parameter.
struct ParamSpec {
    std::string name;
    double lo, hi;
    double step_abs;  ///< finite-difference step floor
};

/// An effect fitted by discovery: its finite-difference step floor and, where the fit must stay
/// inside the simulator's range (sim::Effects::range, the one definition), the lower end and why.
struct EffectFit {
    const char* name;
    double step_abs;
    double fit_lo;  ///< NaN: the simulator's lower end
};
constexpr double kSimulatorLo = std::numeric_limits<double>::quiet_NaN();
constexpr EffectFit kEffectFits[] = {
    {"viscous", 1e-7, kSimulatorLo},
    {"stribeck_amplitude", 2e-3, kSimulatorLo},
    // the simulator takes 1e-6 rad/s; a fit starts at its 1 rad/s step, so a step never leaves the range
    {"stribeck_speed", 1.0, 1.0},
    {"spall_amplitude", 2e-3, kSimulatorLo},
    {"spall_center", 0.02, kSimulatorLo},
    // the simulator takes 1e-6 deg; a fit keeps 2.5 of its 0.02 deg steps above zero
    {"spall_width", 0.02, 0.05},
    {"ripple_amplitude", 2e-3, kSimulatorLo},
    {"current_gain_error", 2e-4, kSimulatorLo},
    {"hinge_offset", 0.5, kSimulatorLo},
    // the simulator reads 0 as "the datasheet J"; a fitted inertia is one step above it
    {"true_inertia", 1e-7, 1e-7},
};

const std::vector<ParamSpec>& specs() {
    static const std::vector<ParamSpec> all = [] {
        std::vector<ParamSpec> v = {
            {"fdj_nm", 0.0, 10.0, 2e-4},
            {"eta_o", 0.3, 0.9999, 2e-3},  // below 1: eq. (4) gives eta_A = 1 at eta_O = 1, outside the simulator range
        };
        for (const auto& e : kEffectFits) {
            const sim::Effects::Range r = sim::Effects::range(e.name);
            v.push_back({e.name, std::isnan(e.fit_lo) ? r.min : e.fit_lo, r.max, e.step_abs});
        }
        return v;
    }();
    return all;
}
/// Relative finite-difference step (the simulator's chatter makes smaller steps noisy).
constexpr double kStepRel = 0.005;

/// Coefficients of sim::Term entries are named "term:K" (K the index in EmaParams::terms): any
/// value; the step is relative (kStepRel) with this floor.
const ParamSpec kTermSpec = {"term", -1e12, 1e12, 1e-12};

std::size_t term_index(const std::string& name, const sim::EmaParams& p) {
    const std::size_t k = std::stoul(name.substr(5));
    if (k >= p.terms.size()) {
        throw EmadiagError("discovery: parameter '" + name + "': the model has " + std::to_string(p.terms.size()) +
                           " terms");
    }
    return k;
}

const ParamSpec& spec(const std::string& name) {
    if (is_term_parameter(name)) return kTermSpec;
    for (const auto& s : specs()) {
        if (name == s.name) return s;
    }
    throw EmadiagError("discovery: parameter '" + name + "' cannot be fitted");
}

double rms(double sum_sq, std::size_t n) { return n ? std::sqrt(sum_sq / static_cast<double>(n)) : 0.0; }

/// Threads for a batch of re-simulations (two cores is what a ramp laptop has).
unsigned batch_threads() { return std::max(1u, std::min(2u, std::thread::hardware_concurrency())); }

/// The re-simulated run of `c` and its result, checked as resimulate does.
Run finish_resimulation(const Run& run, const sim::SimConfig& c, const sim::SimResult& r) {
    if (!r.finite) throw EmadiagError("discovery: the re-simulation diverged (NaN or inf)");
    Run out = make_run(c, r);
    out.constants = run.constants;
    if (out.samples.size() != run.samples.size()) {
        throw EmadiagError("discovery: the re-simulation has " + std::to_string(out.samples.size()) +
                           " samples, the run " + std::to_string(run.samples.size()));
    }
    return out;
}

}  // namespace

std::vector<double> trajectory_rows(const RunSignals& a, const RunSignals& b, const NoiseFloor& f) {
    if (a.size() != b.size()) {
        throw EmadiagError("discovery: model and measurement differ in length (" + std::to_string(b.size()) + " and " +
                           std::to_string(a.size()) + " samples)");
    }
    const std::size_t n = a.size();
    std::vector<double> rows(kTrajectoryChannels * n, 0.0);
    const std::pair<const std::vector<double>*, const std::vector<double>*> ch[kTrajectoryChannels] = {
        {&a.current_a, &b.current_a}, {&a.speed_rad_s, &b.speed_rad_s}, {&a.theta_m_rad, &b.theta_m_rad},
        {&a.load_torque_nm, &b.load_torque_nm}};
    const double floors[kTrajectoryChannels] = {f.current_a, f.speed_rad_s, f.theta_rad, f.load_nm};
    for (std::size_t c = 0; c < kTrajectoryChannels; ++c) {
        if (!(floors[c] > 0)) continue;
        for (std::size_t k = 0; k < n; ++k) rows[c * n + k] = ((*ch[c].first)[k] - (*ch[c].second)[k]) / floors[c];
    }
    return rows;
}

bool is_term_parameter(const std::string& name) {
    return name.size() > 5 && name.compare(0, 5, "term:") == 0 &&
           name.find_first_not_of("0123456789", 5) == std::string::npos;
}

FitRange fit_range(const std::string& name) {
    const ParamSpec& s = spec(name);
    return {s.lo, s.hi};
}

std::vector<std::string> fitted_effect_names() {
    std::vector<std::string> v;
    for (const auto& e : kEffectFits) v.emplace_back(e.name);
    return v;
}

std::string term_parameter(std::size_t index) { return "term:" + std::to_string(index); }

double get_parameter(const sim::EmaParams& p, const std::string& name) {
    if (is_term_parameter(name)) return p.terms[term_index(name, p)].coefficient;
    if (name == "fdj_nm") return p.fdj_nm;
    if (name == "eta_o") return p.eta_o;
    (void)spec(name);
    return p.effects.get(name);
}

void set_parameter(sim::EmaParams& p, const std::string& name, double value) {
    const ParamSpec& s = spec(name);
    value = std::clamp(value, s.lo, s.hi);
    if (is_term_parameter(name)) {
        p.terms[term_index(name, p)].coefficient = value;
    } else if (name == "fdj_nm") {
        p.fdj_nm = value;
        p.fsj_nm = std::max(p.fsj_nm, p.fdj_nm);
    } else if (name == "eta_o") {
        p.eta_o = value;
        p.eta_a = sim::eta_a_from_eta_o(value, p.tau);
    } else {
        p.effects.set(name, value);
    }
}

sim::SimConfig resim_config(const Run& run, const sim::EmaParams& params) {
    sim::SimConfig c;
    c.params = params;
    c.params.k_t_nm_per_a = run.constants.k_t_nm_per_a;
    c.params.j_kgm2 = run.constants.j_kgm2;
    c.params.tau = run.constants.tau;
    c.load_case = run.load_case;
    c.sequence = run.sequence;
    c.noise = sim::NoiseProfile::None;
    c.duration_s = static_cast<double>(run.samples.size()) * sim::kSamplePeriodS;
    return c;
}

Run resimulate(const Run& run, const sim::EmaParams& params) {
    const sim::SimConfig c = resim_config(run, params);
    return finish_resimulation(run, c, sim::simulate(c));
}

std::vector<Run> resimulate_many(const Run& run, const std::vector<sim::EmaParams>& params) {
    std::vector<Run> out;
    if (params.empty()) return out;
    std::vector<sim::SimConfig> configs;
    configs.reserve(params.size());
    bool shared_backlash = true;
    for (const auto& p : params) {
        configs.push_back(resim_config(run, p));
        shared_backlash = shared_backlash && p.effects.backlash_rad == params[0].effects.backlash_rad;
    }
    std::vector<sim::SimResult> results;
    if (shared_backlash) {
        results = sim::simulate_batch(configs, batch_threads());
    } else {
        for (const auto& c : configs) results.push_back(sim::simulate(c));
    }
    out.reserve(params.size());
    for (std::size_t i = 0; i < configs.size(); ++i) out.push_back(finish_resimulation(run, configs[i], results[i]));
    return out;
}

std::vector<char> comparison_mask(const RunSignals& measured, const RunSignals& model) {
    const std::size_t n = std::min(measured.size(), model.size());
    std::vector<char> kink(n, 0);
    for (const auto* w : {&model.speed_rad_s, &measured.speed_rad_s}) {
        for (std::size_t k = 1; k + 1 < n; ++k) {
            if (std::abs((*w)[k + 1] - 2 * (*w)[k] + (*w)[k - 1]) > kKinkSecondDifferenceRadS) kink[k] = 1;
        }
    }
    std::vector<char> m(measured.size(), 0);
    for (std::size_t k = 1; k + 1 < n; ++k) {
        m[k] = measured.slipping[k] && model.slipping[k] && !kink[k - 1] && !kink[k] && !kink[k + 1];
    }
    return m;
}

ErrorMetrics model_error(const RunSignals& a, const RunSignals& b, const std::vector<char>& mask) {
    if (a.size() != b.size() || mask.size() != a.size()) {
        throw EmadiagError("discovery: model and measurement differ in length (" + std::to_string(b.size()) +
                           " and " + std::to_string(a.size()) + " samples)");
    }
    ErrorMetrics e;
    e.samples = a.size();
    double si = 0, sw = 0, sth = 0, st = 0, swin = 0;
    std::size_t nwin = 0;
    double acc = 0;
    std::size_t in_win = 0;
    for (std::size_t k = 0; k < a.size(); ++k) {
        si += std::pow(a.current_a[k] - b.current_a[k], 2);
        sw += std::pow(a.speed_rad_s[k] - b.speed_rad_s[k], 2);
        sth += std::pow(a.theta_m_rad[k] - b.theta_m_rad[k], 2);
        if (mask[k]) {
            const double d = a.residual_torque_nm[k] - b.residual_torque_nm[k];
            st += d * d;
            ++e.torque_samples;
            acc += d;
            if (++in_win == kMetricWindowSamples) {
                swin += std::pow(acc / static_cast<double>(in_win), 2);
                ++nwin;
                acc = 0;
                in_win = 0;
            }
        } else {
            acc = 0;  // a window is consecutive samples only
            in_win = 0;
        }
    }
    e.current_rms_a = rms(si, a.size());
    e.speed_rms_rad_s = rms(sw, a.size());
    e.theta_rms_rad = rms(sth, a.size());
    e.residual_torque_rms_nm = rms(st, e.torque_samples);
    e.residual_torque_window_rms_nm = rms(swin, nwin);
    return e;
}

FitResult fit_by_resimulation(const Run& run, const RunSignals& measured, const sim::EmaParams& start,
                              const std::vector<std::string>& names, const std::vector<char>& mask,
                              double fsj_base_nm, std::size_t window_samples, const sim::EmaParams* reference,
                              int max_iterations, const NoiseFloor* trajectory_floor) {
    FitResult fr;
    // Rows: sums of the torque residual over windows of up to kFitWindowSamples consecutive masked
    // samples (the derivative noise of eq. 7 telescopes in a window sum).
    std::vector<std::vector<std::size_t>> windows;
    for (std::size_t k = 0; k < mask.size(); ++k) {
        if (!mask[k]) continue;
        if (windows.empty() || windows.back().size() >= window_samples || windows.back().back() + 1 != k) {
            windows.emplace_back();
        }
        windows.back().push_back(k);
    }
    const auto m = static_cast<Eigen::Index>(trajectory_floor != nullptr ? kTrajectoryChannels * measured.size()
                                                                         : windows.size());
    const auto np = static_cast<Eigen::Index>(names.size());
    // The window sums of measured minus model T_R for a re-simulated run's signals (or the
    // trajectory rows in noise floors).
    auto residual_of = [&](const RunSignals& sim_s) {
        if (trajectory_floor != nullptr) {
            const std::vector<double> rows = trajectory_rows(measured, sim_s, *trajectory_floor);
            return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(rows.data(), static_cast<Eigen::Index>(rows.size())));
        }
        Eigen::VectorXd e(m);
        for (Eigen::Index i = 0; i < m; ++i) {
            double sum = 0;
            for (std::size_t k : windows[static_cast<std::size_t>(i)]) {
                sum += measured.residual_torque_nm[k] - sim_s.residual_torque_nm[k];
            }
            e(i) = sum;
        }
        return e;
    };
    // One batch of re-simulations (resimulate_many: side by side in SIMD lanes) evaluates a trial
    // point q together with the forward-difference steps around it, so that when q is accepted the
    // next iteration's Jacobian is already there. The further trials of the iteration (larger
    // damping, each known before any is simulated: they differ only in lambda) run without their
    // steps, in the free lanes of that batch or together in the next, and the steps follow for the
    // one accepted. Every value is that of simulating each point alone (the lanes give the scalar path's results
    // bit for bit), so the fit is the same, bit for bit, as trying one point after another.
    struct Point {
        sim::EmaParams params;
        Eigen::VectorXd e;                     ///< window sums of measured - model T_R at params
        RunSignals signals;                    ///< the re-simulation at params
        std::vector<Eigen::VectorXd> stepped;  ///< the same at params + h_j along parameter j
        std::vector<double> actual;            ///< h_j after clamping to the parameter's range
        bool with_point = true;                ///< evaluate: simulate params (false: e, signals known)
        bool with_steps = true;                ///< evaluate: simulate the steps
    };
    auto with_fsj = [&](sim::EmaParams q) {
        q.fsj_nm = std::max(fsj_base_nm, q.fdj_nm);
        return q;
    };
    // Evaluates each of `points` (unless its with_point is false: its e and signals are known
    // already), with its steps when its with_steps, and `extra`, whose residual goes to *extra_e.
    auto evaluate = [&](std::vector<Point>& points, const sim::EmaParams* extra, Eigen::VectorXd* extra_e) {
        std::vector<sim::EmaParams> batch;
        for (auto& pt : points) {
            if (pt.with_point) batch.push_back(with_fsj(pt.params));
            if (!pt.with_steps) continue;
            pt.actual.assign(static_cast<std::size_t>(np), 0.0);
            for (Eigen::Index j = 0; j < np; ++j) {
                const auto ju = static_cast<std::size_t>(j);
                const std::string& name = names[ju];
                const ParamSpec& sp = spec(name);
                const double v = get_parameter(pt.params, name);
                double h = std::max(sp.step_abs, kStepRel * std::abs(v));
                if (v + h > sp.hi) h = -h;
                sim::EmaParams q = pt.params;
                set_parameter(q, name, v + h);
                pt.actual[ju] = get_parameter(q, name) - v;
                batch.push_back(with_fsj(q));
            }
        }
        if (extra != nullptr) batch.push_back(with_fsj(*extra));
        const std::vector<Run> runs = resimulate_many(run, batch);
        fr.simulations += static_cast<int>(runs.size());
        std::size_t k = 0;
        for (auto& pt : points) {
            if (pt.with_point) {
                pt.signals = run_signals(runs[k++]);
                pt.e = residual_of(pt.signals);
            }
            if (!pt.with_steps) continue;
            pt.stepped.clear();
            for (Eigen::Index j = 0; j < np; ++j) pt.stepped.push_back(residual_of(run_signals(runs[k++])));
        }
        if (extra != nullptr) *extra_e = residual_of(run_signals(runs[k]));
    };
    fr.rows = static_cast<std::size_t>(m);
    std::vector<Point> current(1);
    current[0].params = start;
    Eigen::VectorXd e_reference;
    evaluate(current, reference, &e_reference);
    if (reference != nullptr) fr.cost_reference = e_reference.squaredNorm();
    sim::EmaParams p = start;
    Eigen::VectorXd e = current[0].e;
    fr.cost_start = e.squaredNorm();
    double cost = fr.cost_start;
    double lambda = kFitStartDamping;
    Eigen::MatrixXd jac(m, np);
    Point at_p = std::move(current[0]);  // p with its steps
    for (int it = 0; it < max_iterations; ++it) {
        fr.iterations = it + 1;
        // Forward differences of the model's T_R (e = y - f, so df = -(e_step - e)).
        for (Eigen::Index j = 0; j < np; ++j) {
            const auto ju = static_cast<std::size_t>(j);
            jac.col(j) = -(at_p.stepped[ju] - e) / at_p.actual[ju];
        }
        const Eigen::MatrixXd jtj = jac.transpose() * jac;
        const Eigen::VectorXd jte = jac.transpose() * e;
        // The trial point at damping lam.
        auto trial_at = [&](double lam) {
            Eigen::MatrixXd a = jtj;
            a.diagonal() += lam * jtj.diagonal().cwiseMax(1e-30);
            const Eigen::VectorXd delta = a.ldlt().solve(jte);
            Point q;
            q.params = p;
            for (Eigen::Index j = 0; j < np; ++j) {
                const std::string& name = names[static_cast<std::size_t>(j)];
                set_parameter(q.params, name, get_parameter(p, name) + delta(j));
            }
            return q;
        };
        bool improved = false;
        auto accept = [&](Point& q) {
            const double cq = q.e.squaredNorm();
            const double gain = (cost - cq) / cost;
            p = q.params;
            e = q.e;
            at_p = std::move(q);
            cost = cq;
            lambda = std::max(lambda / 10.0, 1e-9);
            improved = true;
            if (gain < kFitRelativeTolerance) it = max_iterations;  // converged
        };
        // The trials at lambda, 10 lambda, ... in order; the first that lowers the cost is taken. The
        // first goes with its steps; further ones share its batch while they fill the last vector's
        // free lanes (no more vector passes), the rest follow in one batch if the first ones fail.
        std::vector<double> lambdas;
        std::vector<Point> trials;
        for (int tries = 0; tries < kFitTriesPerIteration; ++tries) {
            lambdas.push_back(lambda);
            trials.push_back(trial_at(lambda));
            trials.back().with_steps = tries == 0;
            lambda *= 10.0;  // the damping after this trial fails
        }
        const auto first_lanes = static_cast<std::size_t>(1 + np);
        const std::size_t vector_lanes = std::max(1, sim::simd_target().lanes);
        const std::size_t free_lanes = (vector_lanes - first_lanes % vector_lanes) % vector_lanes;
        const std::size_t first_batch = std::min(trials.size(), 1 + free_lanes);
        std::size_t evaluated = 0;
        while (!improved && evaluated < trials.size()) {
            const std::size_t count = evaluated == 0 ? first_batch : trials.size() - evaluated;
            std::vector<Point> batch(std::make_move_iterator(trials.begin() + static_cast<std::ptrdiff_t>(evaluated)),
                                     std::make_move_iterator(trials.begin() + static_cast<std::ptrdiff_t>(evaluated + count)));
            evaluate(batch, nullptr, nullptr);
            for (std::size_t i = 0; i < batch.size() && !improved; ++i) {
                if (!(batch[i].e.squaredNorm() < cost)) continue;
                lambda = lambdas[evaluated + i];
                if (!batch[i].with_steps) {
                    batch[i].with_point = false;
                    batch[i].with_steps = true;
                    std::vector<Point> accepted(1, std::move(batch[i]));
                    evaluate(accepted, nullptr, nullptr);
                    accept(accepted[0]);
                } else {
                    accept(batch[i]);
                }
            }
            evaluated += count;
        }
        if (!improved) break;
    }
    fr.params = p;
    fr.params.fsj_nm = std::max(fsj_base_nm, p.fdj_nm);
    fr.cost_end = cost;
    fr.signals = std::move(at_p.signals);
    // Standard errors from the last Jacobian: cov = s^2 (J^T J)^-1, s^2 = cost / (m - p).
    const Eigen::MatrixXd jtj = jac.transpose() * jac;
    const double s2 = cost / std::max<double>(1.0, static_cast<double>(m - np));
    const Eigen::MatrixXd cov = s2 * jtj.completeOrthogonalDecomposition().pseudoInverse();
    for (Eigen::Index j = 0; j < np; ++j) {
        const std::string& name = names[static_cast<std::size_t>(j)];
        fr.values.push_back({name, get_parameter(p, name), std::sqrt(std::max(0.0, cov(j, j)))});
    }
    return fr;
}

}  // namespace emadiag::discovery
