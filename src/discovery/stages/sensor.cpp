// Stage 4, sensor: the angle channel, which the torque residual does not see: a position sensor
// offset and drift, kept only when the trajectory tells it from the model's own parameters refitted.
#include "discovery/stages/stages.hpp"

#include "discovery/fits/fits.hpp"
#include "discovery/physics_names.hpp"
#include "discovery/screening/screen_windows.hpp"

#include <algorithm>
#include <cmath>

namespace emadiag::discovery::pipeline {
namespace {

/// Smallest RMS (in noise floors) of a position sensor offset and drift the sensor stage adds.
constexpr double kSensorMinRmsFloors = kStructureMinExcessTheta;
/// The sensor stage's offset and drift must together explain this share of the angle residual's sum
/// of squares, and each of them this share on its own when both are kept.
constexpr double kSensorMinExplained = 0.8;
/// ... and only when the current and speed residuals are within this many floors (RMS).
constexpr double kSensorOtherChannelsMax = 1.25;
constexpr double kSensorMinShare = 0.1;
/// Samples at the start of the run (before the motion) that must show a sensor offset.
constexpr std::size_t kSensorStartSamples = 10;
/// The angle channel, which the torque residual does not see: a position sensor offset and drift
/// (theta: c0 + c1 t), selected by the BIC on the samples against the angle's noise floor, added when
/// the channel is significantly above its floor and the re-simulated trajectory confirms it.
void position_sensor_fit(const Run& run, const RunSignals& s, const NoiseFloor& floor, const std::vector<char>& mask,
                  sim::EmaParams& p, RunSignals& model_sim, TrajectoryError& traj_now, DiscoveryReport& rep) {
    const std::size_t n = s.size();
    std::vector<double> e(n);
    for (std::size_t k = 0; k < n; ++k) e[k] = s.theta_m_rad[k] - model_sim.theta_m_rad[k];
    const auto reports = structure_reports(s, model_sim, mask, floor);
    const StructureReport* theta = nullptr;
    for (const auto& r : reports) {
        if (r.channel == "theta") theta = &r;
    }
    if (theta == nullptr || !theta->significant) return;
    // A position sensor error does not move the current or the speed: the sensor stage runs only when
    // both are at their floor (a torque the model lacks moves all three).
    for (const auto& r : reports) {
        if ((r.channel == "current" || r.channel == "speed") && r.rms > kSensorOtherChannelsMax * r.floor) {
            rep.notes.push_back("position sensor stage: the angle residual is above its floor, but so is the " + r.channel +
                                " residual (" + std::to_string(r.rms / r.floor) +
                                " x its floor): a sensor error would not move it; not named a sensor error");
            return;
        }
    }
    const double sigma2 = floor.theta_rad * floor.theta_rad;
    const double dn = static_cast<double>(n);
    // Least squares of e on {1}, {t}, {1, t}.
    double s1 = 0, st = 0, stt = 0, se = 0, ste = 0, see = 0;
    for (std::size_t k = 0; k < n; ++k) {
        const double t = s.t_s[k];
        s1 += 1;
        st += t;
        stt += t * t;
        se += e[k];
        ste += t * e[k];
        see += e[k] * e[k];
    }
    struct Option {
        bool offset, drift;
        double c0, c1, rss;
    };
    std::vector<Option> options;
    options.push_back({false, false, 0, 0, see});
    options.push_back({true, false, se / s1, 0, see - se * se / s1});
    options.push_back({false, true, 0, ste / stt, see - ste * ste / stt});
    {
        const double det = s1 * stt - st * st;
        const double c0 = (stt * se - st * ste) / det, c1 = (s1 * ste - st * se) / det;
        options.push_back({true, true, c0, c1, see - c0 * se - c1 * ste});
    }
    // Effect size of each part: RMS over the run of the offset and of the drift.
    auto large = [&](const Option& o) {
        double s_off = 0, s_drift = 0;
        for (std::size_t k = 0; k < n; ++k) s_drift += std::pow(o.c1 * s.t_s[k], 2);
        s_off = o.c0 * o.c0 * dn;
        const double limit = kSensorMinRmsFloors * floor.theta_rad;
        return (!o.offset || std::sqrt(s_off / dn) >= limit) && (!o.drift || std::sqrt(s_drift / dn) >= limit);
    };
    std::size_t best = 0;
    double best_bic = see / sigma2;
    for (std::size_t i = 1; i < options.size(); ++i) {
        if (!large(options[i])) continue;
        const double k = (options[i].offset ? 1.0 : 0.0) + (options[i].drift ? 1.0 : 0.0);
        const double bic = std::max(options[i].rss, 0.0) / sigma2 + k * std::log(dn) + 2.0 * std::log(3.0);
        if (bic < best_bic) {
            best_bic = bic;
            best = i;
        }
    }
    if (best == 0) return;
    // Both parts only when each explains a share of its own (otherwise the smaller is what the other
    // leaves); and the sensor terms must explain most of the angle residual: a residual shaped like
    // the speed (a lag of the closed loop behind a torque the model lacks) is not a sensor's.
    if (options[best].offset && options[best].drift &&
        (options[3].rss > options[1].rss - kSensorMinShare * see || options[3].rss > options[2].rss - kSensorMinShare * see)) {
        best = options[1].rss < options[2].rss ? 1 : 2;
        if (!large(options[best])) return;
    }
    const Option& o = options[best];
    // A sensor offset is there from the first sample, before anything moves; an angle offset that a
    // torque the model lacks leaves builds up during the run (e.g. a position-dependent torque
    // holding the shaft off the command at rest).
    if (o.offset) {
        double start = 0;
        const std::size_t m = std::min<std::size_t>(kSensorStartSamples, n);
        for (std::size_t k = 0; k < m; ++k) start += e[k] - (o.drift ? o.c1 * s.t_s[k] : 0.0);
        start /= static_cast<double>(m);
        if (std::abs(start - o.c0) > 0.5 * std::abs(o.c0)) {
            rep.notes.push_back("position sensor stage: an angle offset of " + std::to_string(o.c0) +
                                " rad fits the run, but the first samples show " + std::to_string(start) +
                                " rad: it builds up during the run, so it is not a sensor offset");
            return;
        }
    }
    if (o.rss > (1.0 - kSensorMinExplained) * see) {
        rep.notes.push_back("position sensor stage: an offset/drift explains only " +
                            std::to_string(100.0 * (1.0 - o.rss / see)) +
                            " % of the angle residual; left as structure, not named a sensor error");
        return;
    }
    sim::EmaParams q = p;
    std::vector<sim::Term> added;
    if (o.offset) added.push_back(make_term(sim::TermTarget::Theta, o.c0, {}));
    if (o.drift) added.push_back(make_term(sim::TermTarget::Theta, o.c1, {{sim::TermBasis::Identity, sim::TermSignal::Time, 0, 0}}));
    const double resid_var = std::max(o.rss, 0.0) / std::max(1.0, dn - static_cast<double>(added.size()));
    for (auto& t : added) {
        t.std_error = std::sqrt(resid_var / (t.factors.empty() ? s1 : stt));
        q.terms.push_back(t);
    }
    const RunSignals q_sim = run_signals(resimulate(run, q));
    const TrajectoryError te = trajectory_error(s, q_sim, floor);
    if (!(te.cost < traj_now.cost)) {
        rep.notes.push_back("position sensor stage: the angle residual is above its floor, but adding " +
                            added.front().text() + " does not bring the trajectory closer (cost " +
                            std::to_string(traj_now.cost) + " -> " + std::to_string(te.cost) + ")");
        return;
    }
    for (const auto& t : added) {
        const PhysicsName nm = physics_name(t);
        rep.sensor_findings.push_back({nm.key, nm.text, t, traj_now.cost, te.cost});
        rep.model.term_keys.push_back(nm.key);
        rep.model.term_texts.push_back(nm.text);
    }
    p = q;
    model_sim = q_sim;
    traj_now = te;
}

}  // namespace

void sensor_stage(Context& ctx) {
    sim::EmaParams& p = ctx.params;
    TrajectoryError& traj_now = ctx.traj_now;
    DiscoveryReport& rep = ctx.rep;
    const sim::EmaParams p_before = p;
    const TrajectoryError traj_before = traj_now;
    const AugmentedModel model_before = rep.model;
    position_sensor_fit(ctx.run, ctx.signals, ctx.floor, ctx.mask, p, ctx.model_sim, traj_now, rep);
    if (!rep.sensor_findings.empty() && steps_added(rep)) {
        // A sensor offset or drift against the model's own parameters refitted on the trajectory: the
        // torque rounds fit each effect on the torque windows, and what that fit leaves in the angle
        // can look like a drift (seed 127's ripple fitted 0.0465 N m, truth 0.0402: trajectory cost
        // 9.9, a "drift" took it to 2.3). The sensor terms stay only when the trajectory tells them
        // apart from the refit (kHypothesisRatio); otherwise the model needs nothing new.
        const double sensor_cost = traj_now.cost;
        try {
            const TrajectoryRefit r = refit_on_trajectory(ctx, p_before);
            if (!(kHypothesisRatio * sensor_cost < r.cost)) {
                rep.notes.push_back("position sensor stage: " + rep.sensor_findings.front().text + " (trajectory cost " +
                                    fmt3(sensor_cost) + ") is not told apart from the model's own parameters refitted on the "
                                    "trajectory (cost " + fmt3(traj_before.cost) + " -> " + fmt3(r.cost) + "); not named, the refit kept");
                rep.sensor_findings.clear();
                rep.model = model_before;
                adopt_trajectory_fit(ctx, r.fit);
            }
        } catch (const std::exception& e) {
            rep.notes.push_back(std::string("position sensor stage: the refit on the trajectory not possible: ") + e.what());
        }
    }
}

}  // namespace emadiag::discovery::pipeline
