#include "discovery/model/resimulation.hpp"

#include "core/emadiag_error.hpp"
#include "core/sim_run.hpp"
#include "estimation/number_text.hpp"
#include "estimation/run_checks.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <optional>
#include <thread>
#include <utility>

namespace emadiag::discovery {
namespace {

/// Relative finite-difference step (the simulator's chatter makes smaller steps noisy); at least
/// fit_step_floor of the parameter.
constexpr double kStepRel = 0.005;

double rms(double sum_sq, std::size_t n) { return n ? std::sqrt(sum_sq / static_cast<double>(n)) : 0.0; }

/// Threads for a batch of re-simulations (two cores is what a ramp laptop has).
unsigned batch_threads() { return std::max(1u, std::min(2u, std::thread::hardware_concurrency())); }

void check_resimulation(const ResimTarget& target, const sim::SimResult& r) {
    if (!r.finite) throw EmadiagError("discovery: the re-simulation diverged (NaN or inf)");
    if (r.samples.size() != target.samples) {
        throw EmadiagError("discovery: the re-simulation has " + std::to_string(r.samples.size()) +
                           " samples, the run " + std::to_string(target.samples));
    }
}

/// The re-simulated run of `c` and its result, checked as resimulate does.
Run finish_resimulation(const ResimTarget& target, const sim::SimConfig& c, const sim::SimResult& r) {
    check_resimulation(target, r);
    Run out = make_run(c, r);
    out.constants = target.constants;
    return out;
}

/// The signals of a re-simulation: its samples with the measured run's constants (as
/// finish_resimulation's Run, without its metadata and without checking it again).
RunSignals finish_resimulation_signals(const ResimTarget& target, const sim::SimResult& r) {
    check_resimulation(target, r);
    Run bare;
    bare.constants = target.constants;
    bare.samples = r.samples;
    return unchecked_run_signals(bare);
}

/// One sim::simulate_batch of every config on two threads when their params share the backlash
/// (the lanes share it), else one simulation after another.
std::vector<sim::SimResult> simulate_all(const std::vector<sim::SimConfig>& configs) {
    bool shared_backlash = true;
    for (const auto& c : configs) {
        shared_backlash = shared_backlash && c.params.effects.backlash_rad == configs[0].params.effects.backlash_rad;
    }
    std::vector<sim::SimResult> results;
    if (shared_backlash) {
        results = sim::simulate_batch(configs, batch_threads());
    } else {
        for (const auto& c : configs) results.push_back(sim::simulate(c));
    }
    return results;
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

ResimTarget resim_target(const Run& run) {
    const RunConstants& c = run.constants;
    if (std::abs(sim::kSamplePeriodS - c.sample_period_s) > kSamplePeriodTolerance * c.sample_period_s) {
        throw EmadiagError("discovery: the run's sample_period_s " + number_text(c.sample_period_s) +
                           " s is not the simulator's " + number_text(sim::kSamplePeriodS) + " s (within " +
                           number_text(100 * kSamplePeriodTolerance) + " %): the run cannot be re-simulated");
    }
    return ResimTarget{run.load_case, run.sequence, run.samples.size(), c};
}

sim::SimConfig resim_config(const ResimTarget& target, const sim::EmaParams& params) {
    sim::SimConfig c;
    c.params = params;
    c.params.k_t_nm_per_a = target.constants.k_t_nm_per_a;
    c.params.j_kgm2 = target.constants.j_kgm2;
    c.params.tau = target.constants.tau;
    c.load_case = target.load_case;
    c.sequence = target.sequence;
    c.noise = sim::NoiseProfile::None;
    c.duration_s = static_cast<double>(target.samples) * sim::kSamplePeriodS;
    return c;
}

sim::SimConfig resim_config(const Run& run, const sim::EmaParams& params) { return resim_config(resim_target(run), params); }

Run resimulate(const Run& run, const sim::EmaParams& params) {
    const ResimTarget target = resim_target(run);
    const sim::SimConfig c = resim_config(target, params);
    return finish_resimulation(target, c, sim::simulate(c));
}

std::vector<Run> resimulate_many(const Run& run, const std::vector<sim::EmaParams>& params) {
    std::vector<Run> out;
    if (params.empty()) return out;
    const ResimTarget target = resim_target(run);
    std::vector<sim::SimConfig> configs;
    configs.reserve(params.size());
    for (const auto& p : params) configs.push_back(resim_config(target, p));
    const std::vector<sim::SimResult> results = simulate_all(configs);
    out.reserve(params.size());
    for (std::size_t i = 0; i < configs.size(); ++i) out.push_back(finish_resimulation(target, configs[i], results[i]));
    return out;
}

RunSignals resimulate_signals(const ResimTarget& target, const sim::EmaParams& params) {
    return finish_resimulation_signals(target, sim::simulate(resim_config(target, params)));
}

std::vector<RunSignals> resimulate_signals_many(const ResimTarget& target, const std::vector<sim::EmaParams>& params) {
    std::vector<RunSignals> out;
    if (params.empty()) return out;
    std::vector<sim::SimConfig> configs;
    configs.reserve(params.size());
    for (const auto& p : params) configs.push_back(resim_config(target, p));
    const std::vector<sim::SimResult> results = simulate_all(configs);
    out.reserve(params.size());
    for (const auto& r : results) out.push_back(finish_resimulation_signals(target, r));
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

namespace {

/// The rows of a fit: sums of the torque residual over windows of up to `window_samples` consecutive
/// masked samples (the derivative noise of eq. 7 telescopes in a window sum), or with a
/// `trajectory_floor` the trajectory rows in noise floors.
class FitRows {
public:
    FitRows(const RunSignals& measured, const std::vector<char>& mask, std::size_t window_samples,
            const NoiseFloor* trajectory_floor)
        : measured_(measured), trajectory_floor_(trajectory_floor) {
        for (std::size_t k = 0; k < mask.size(); ++k) {
            if (!mask[k]) continue;
            if (windows_.empty() || windows_.back().size() >= window_samples || windows_.back().back() + 1 != k) {
                windows_.emplace_back();
            }
            windows_.back().push_back(k);
        }
        m_ = static_cast<Eigen::Index>(trajectory_floor != nullptr ? kTrajectoryChannels * measured.size() : windows_.size());
    }
    [[nodiscard]] Eigen::Index count() const { return m_; }
    /// The window sums of measured minus model T_R for a re-simulated run's signals (or the
    /// trajectory rows in noise floors).
    [[nodiscard]] Eigen::VectorXd residual_of(const RunSignals& sim_s) const {
        if (trajectory_floor_ != nullptr) {
            const std::vector<double> rows = trajectory_rows(measured_, sim_s, *trajectory_floor_);
            return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(rows.data(), static_cast<Eigen::Index>(rows.size())));
        }
        Eigen::VectorXd e(m_);
        for (Eigen::Index i = 0; i < m_; ++i) {
            double sum = 0;
            for (std::size_t k : windows_[static_cast<std::size_t>(i)]) {
                sum += measured_.residual_torque_nm[k] - sim_s.residual_torque_nm[k];
            }
            e(i) = sum;
        }
        return e;
    }

private:
    const RunSignals& measured_;
    const NoiseFloor* trajectory_floor_;
    std::vector<std::vector<std::size_t>> windows_;
    Eigen::Index m_ = 0;
};

/// A point of the Levenberg-Marquardt fit, with what its evaluation gives.
struct FitPoint {
    sim::EmaParams params;
    Eigen::VectorXd e;                     ///< window sums of measured - model T_R at params
    RunSignals signals;                    ///< the re-simulation at params
    std::vector<Eigen::VectorXd> stepped;  ///< the same at params + h_j along parameter j
    std::vector<double> actual;            ///< h_j after clamping to the parameter's range
    bool with_point = true;                ///< evaluate: simulate params (false: e, signals known)
    bool with_steps = true;                ///< evaluate: simulate the steps
};

/// One batch of re-simulations (resimulate_many: side by side in SIMD lanes) evaluates a trial
/// point q together with the forward-difference steps around it, so that when q is accepted the
/// next iteration's Jacobian is already there. The further trials of the iteration (larger
/// damping, each known before any is simulated: they differ only in lambda) run without their
/// steps, in the free lanes of that batch or together in the next, and the steps follow for the
/// one accepted. Every value is that of simulating each point alone (the lanes give the scalar path's results
/// bit for bit), so the fit is the same, bit for bit, as trying one point after another.
class FitEvaluator {
public:
    FitEvaluator(const ResimTarget& target, const std::vector<FitParameter>& parameters, double fsj_base_nm,
                 const FitRows& rows, int& simulations)
        : target_(target), parameters_(parameters), fsj_base_nm_(fsj_base_nm), rows_(rows), simulations_(simulations) {}

    [[nodiscard]] sim::EmaParams with_fsj(sim::EmaParams q) const {
        q.fsj_nm = std::max(fsj_base_nm_, q.fdj_nm);
        return q;
    }
    /// Evaluates each of `points` (unless its with_point is false: its e and signals are known
    /// already), with its steps when its with_steps, and `extra`, whose residual goes to *extra_e.
    void evaluate(std::vector<FitPoint>& points, const sim::EmaParams* extra, Eigen::VectorXd* extra_e) const {
        const auto np = static_cast<Eigen::Index>(parameters_.size());
        std::vector<sim::EmaParams> batch;
        for (auto& pt : points) {
            if (pt.with_point) batch.push_back(with_fsj(pt.params));
            if (!pt.with_steps) continue;
            pt.actual.assign(static_cast<std::size_t>(np), 0.0);
            for (Eigen::Index j = 0; j < np; ++j) {
                const auto ju = static_cast<std::size_t>(j);
                const FitParameter& parameter = parameters_[ju];
                const double v = get_parameter(pt.params, parameter);
                double h = std::max(fit_step_floor(parameter), kStepRel * std::abs(v));
                if (v + h > fit_range(parameter).hi) h = -h;
                sim::EmaParams q = pt.params;
                set_parameter(q, parameter, v + h);
                pt.actual[ju] = get_parameter(q, parameter) - v;
                batch.push_back(with_fsj(q));
            }
        }
        if (extra != nullptr) batch.push_back(with_fsj(*extra));
        std::vector<RunSignals> runs = resimulate_signals_many(target_, batch);
        simulations_ += static_cast<int>(runs.size());
        std::size_t k = 0;
        for (auto& pt : points) {
            if (pt.with_point) {
                pt.signals = std::move(runs[k++]);
                pt.e = rows_.residual_of(pt.signals);
            }
            if (!pt.with_steps) continue;
            pt.stepped.clear();
            for (Eigen::Index j = 0; j < np; ++j) pt.stepped.push_back(rows_.residual_of(runs[k++]));
        }
        if (extra != nullptr) *extra_e = rows_.residual_of(runs[k]);
    }
    [[nodiscard]] const std::vector<FitParameter>& parameters() const { return parameters_; }

private:
    const ResimTarget& target_;
    const std::vector<FitParameter>& parameters_;
    double fsj_base_nm_;
    const FitRows& rows_;
    int& simulations_;
};

/// Where the fit stands: the accepted point p (with its steps), its residual and cost, the damping.
struct FitState {
    sim::EmaParams p;
    Eigen::VectorXd e;
    double cost = 0;
    double lambda = kFitStartDamping;
    FitPoint at_p;
};

enum class FitIteration { Improved, Converged, Stuck };

/// One Levenberg-Marquardt iteration from `st`: the Jacobian into `jac`, then the trials at lambda,
/// 10 lambda, ... until one lowers the cost (Improved, or Converged when it lowers it by less than
/// kFitRelativeTolerance); Stuck when none does.
FitIteration fit_iteration(const FitEvaluator& ev, FitState& st, Eigen::MatrixXd& jac) {
    const std::vector<FitParameter>& parameters = ev.parameters();
    const auto np = static_cast<Eigen::Index>(parameters.size());
    sim::EmaParams& p = st.p;
    Eigen::VectorXd& e = st.e;
    double& cost = st.cost;
    double& lambda = st.lambda;
    FitPoint& at_p = st.at_p;
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
        FitPoint q;
        q.params = p;
        for (Eigen::Index j = 0; j < np; ++j) {
            const FitParameter& parameter = parameters[static_cast<std::size_t>(j)];
            set_parameter(q.params, parameter, get_parameter(p, parameter) + delta(j));
        }
        return q;
    };
    bool improved = false;
    bool converged = false;
    auto accept = [&](FitPoint& q) {
        const double cq = q.e.squaredNorm();
        const double gain = (cost - cq) / cost;
        p = q.params;
        e = q.e;
        at_p = std::move(q);
        cost = cq;
        lambda = std::max(lambda / 10.0, 1e-9);
        improved = true;
        if (gain < kFitRelativeTolerance) converged = true;
    };
    // The trials at lambda, 10 lambda, ... in order; the first that lowers the cost is taken. The
    // first goes with its steps; further ones share its batch while they fill the last vector's
    // free lanes (no more vector passes), the rest follow in one batch if the first ones fail.
    std::vector<double> lambdas;
    std::vector<FitPoint> trials;
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
        std::vector<FitPoint> batch(std::make_move_iterator(trials.begin() + static_cast<std::ptrdiff_t>(evaluated)),
                                    std::make_move_iterator(trials.begin() + static_cast<std::ptrdiff_t>(evaluated + count)));
        ev.evaluate(batch, nullptr, nullptr);
        for (std::size_t i = 0; i < batch.size() && !improved; ++i) {
            if (!(batch[i].e.squaredNorm() < cost)) continue;
            lambda = lambdas[evaluated + i];
            if (!batch[i].with_steps) {
                batch[i].with_point = false;
                batch[i].with_steps = true;
                std::vector<FitPoint> accepted(1, std::move(batch[i]));
                ev.evaluate(accepted, nullptr, nullptr);
                accept(accepted[0]);
            } else {
                accept(batch[i]);
            }
        }
        evaluated += count;
    }
    if (!improved) return FitIteration::Stuck;
    return converged ? FitIteration::Converged : FitIteration::Improved;
}

}  // namespace

FitResult fit_by_resimulation(const Run& run, const RunSignals& measured, const sim::EmaParams& start,
                              const std::vector<FitParameter>& parameters, const std::vector<char>& mask,
                              double fsj_base_nm, std::size_t window_samples, const sim::EmaParams* reference,
                              int max_iterations, const NoiseFloor* trajectory_floor) {
    FitResult fr;
    const FitRows rows(measured, mask, window_samples, trajectory_floor);
    const Eigen::Index m = rows.count();
    const auto np = static_cast<Eigen::Index>(parameters.size());
    const ResimTarget target = resim_target(run);
    const FitEvaluator ev(target, parameters, fsj_base_nm, rows, fr.simulations);
    fr.rows = static_cast<std::size_t>(m);
    std::vector<FitPoint> current(1);
    current[0].params = start;
    Eigen::VectorXd e_reference;
    ev.evaluate(current, reference, &e_reference);
    if (reference != nullptr) fr.cost_reference = e_reference.squaredNorm();
    FitState st;
    st.p = start;
    st.e = current[0].e;
    fr.cost_start = st.e.squaredNorm();
    st.cost = fr.cost_start;
    Eigen::MatrixXd jac(m, np);
    st.at_p = std::move(current[0]);  // p with its steps
    for (int it = 0; it < max_iterations; ++it) {
        fr.iterations = it + 1;
        if (fit_iteration(ev, st, jac) != FitIteration::Improved) break;
    }
    const sim::EmaParams& p = st.p;
    const double cost = st.cost;
    fr.params = p;
    fr.params.fsj_nm = std::max(fsj_base_nm, p.fdj_nm);
    fr.cost_end = cost;
    fr.signals = std::move(st.at_p.signals);
    // Standard errors from the last Jacobian: cov = s^2 (J^T J)^-1, s^2 = cost / (m - p).
    const Eigen::MatrixXd jtj = jac.transpose() * jac;
    const double s2 = cost / std::max<double>(1.0, static_cast<double>(m - np));
    const Eigen::MatrixXd cov = s2 * jtj.completeOrthogonalDecomposition().pseudoInverse();
    for (Eigen::Index j = 0; j < np; ++j) {
        const FitParameter& parameter = parameters[static_cast<std::size_t>(j)];
        fr.values.emplace_back(parameter, get_parameter(p, parameter), std::sqrt(std::max(0.0, cov(j, j))));
    }
    return fr;
}

}  // namespace emadiag::discovery
