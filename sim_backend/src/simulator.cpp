#include "emadiag/sim/simulator.hpp"

#include "emadiag/sim/sim_error.hpp"
#include "step_kernel.hpp"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <random>
#include <mutex>
#include <thread>
#include <exception>

namespace emadiag::sim {

using detail::Lanes;
using detail::Shared;

std::string to_string(LoadCase c) {
    switch (c) {
        case LoadCase::A: return "A";
        case LoadCase::AExt: return "A-ext";
        case LoadCase::B: return "B";
    }
    return "?";
}
std::string to_string(Sequence s) {
    switch (s) {
        case Sequence::Dyn: return "dyn";
        case Sequence::Brk: return "brk";
        case Sequence::Sweep: return "sweep";
    }
    return "?";
}
std::string to_string(NoiseProfile n) { return n == NoiseProfile::None ? "none" : "typical"; }

namespace {
std::string lower(std::string s) {
    for (auto& ch : s) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    return s;
}
}  // namespace

LoadCase parse_load_case(const std::string& s) {
    const std::string v = lower(s);
    if (v == "a") return LoadCase::A;
    if (v == "a-ext" || v == "aext" || v == "a_ext") return LoadCase::AExt;
    if (v == "b") return LoadCase::B;
    throw SimError("unknown load case '" + s + "'; expected A, A-ext or B");
}
Sequence parse_sequence(const std::string& s) {
    const std::string v = lower(s);
    if (v == "dyn") return Sequence::Dyn;
    if (v == "brk") return Sequence::Brk;
    if (v == "sweep") return Sequence::Sweep;
    throw SimError("unknown sequence '" + s + "'; expected dyn, brk or sweep");
}
NoiseProfile parse_noise(const std::string& s) {
    const std::string v = lower(s);
    if (v == "none") return NoiseProfile::None;
    if (v == "typical") return NoiseProfile::Typical;
    throw SimError("unknown noise profile '" + s + "'; expected none or typical");
}

double default_duration_s(Sequence s) { return s == Sequence::Brk ? 0.8 : 0.5; }
double command_deg(Sequence s, double t_s) { return detail::command_deg_inline(s, t_s); }

namespace {

constexpr double kStepRatioTolerance = 1e-9;

long steps_in(double period_s, double dt_s, const char* what) {
    const double ratio = period_s / dt_s;
    const long n = std::lround(ratio);
    if (n < 1 || std::abs(ratio - static_cast<double>(n)) > kStepRatioTolerance * ratio) {
        throw SimError(std::string(what) + " of " + std::to_string(period_s) + " s is not a whole number of steps dt_s = " +
                       std::to_string(dt_s));
    }
    return n;
}

}  // namespace

Shared detail::make_shared(const SimConfig& c) {
    c.params.validate();
    const EmaParams& p = c.params;
    Shared s{};
    s.dt = p.dt_s;
    s.v_dc = p.v_dc_v;
    s.r = p.r_ohm;
    s.l = p.l_h;
    s.k_t = p.k_t_nm_per_a;
    s.i_max = p.i_max_a;
    s.t_max = p.t_max_nm;
    s.w_max = p.w_max_rad_s;
    s.j = p.plant_inertia_kgm2();
    s.inv_j = 1.0 / s.j;
    s.dt_over_l = s.dt / s.l;
    s.dt_inv_j = s.dt * s.inv_j;
    s.inv_tau = 1.0 / p.tau;
    s.tau = p.tau;
    s.k_theta = p.k_theta_per_s;
    s.k_w = p.k_w_a_s_per_rad;
    s.stop_m = p.tau * detail::deg2rad(p.stop_deg);
    s.load_case = c.load_case;
    s.sequence = c.sequence;
    s.fx = p.effects;
    s.torque_terms = detail::has_torque_terms(p.terms) ? &p.terms : nullptr;
    const double duration = c.duration_s > 0.0 ? c.duration_s : default_duration_s(c.sequence);
    s.steps_per_sample = steps_in(kSamplePeriodS, p.dt_s, "sample period");
    s.steps_per_aircraft = steps_in(kAircraftPeriodS, p.dt_s, "aircraft period");
    if (s.steps_per_sample % s.steps_per_aircraft != 0) {
        throw SimError("sample period is not a whole number of aircraft periods at dt_s = " + std::to_string(p.dt_s));
    }
    s.total_samples = steps_in(duration, kSamplePeriodS, "duration");
    s.brk_first_hold_steps = steps_in(kBrkFirstHoldS, p.dt_s, "BRK first hold");
    s.brk_mid_hold_steps = steps_in(kBrkMidHoldS, p.dt_s, "BRK hold");
    return s;
}

namespace {

template <int W>
void load_lane(Lanes<W>& z, int l, const EmaParams& p) {
    detail::lane(z.fdj, l) = p.fdj_nm;
    detail::lane(z.fsj, l) = p.fsj_nm;
    detail::lane(z.c_opp, l) = 1.0 / p.eta_o - 1.0;  // eq. (3), opposing
    detail::lane(z.c_aid, l) = 1.0 - p.eta_a;        // eq. (3), aiding
}

/// Runs G interleaved groups of W lanes from rest to the end; lane l of group g fills out[g * W + l].
/// Interleaving independent groups hides the latency of the step's dependency chain.
template <int W, int G, bool kFull>
void run_lanes(const Shared& shared, Lanes<W>* z, SimResult* out[W * G], bool record_truth) {
    const Shared s = shared;  // a local copy: the lane stores cannot alias it, so its fields stay in registers
    for (int l = 0; l < W * G; ++l) {
        out[l]->samples.resize(static_cast<std::size_t>(s.total_samples));
        if (record_truth) out[l]->truth.resize(static_cast<std::size_t>(s.total_samples));
    }
    const long aircraft_per_sample = s.steps_per_sample / s.steps_per_aircraft;
    const double inv_steps = 1.0 / static_cast<double>(s.steps_per_sample);
    const bool case_b = s.load_case == LoadCase::B;
    using D = typename detail::Vec<W>::D;
    long n = 0;
    for (long k = 0; k < s.total_samples; ++k) {
        for (int g = 0; g < G; ++g) {
            z[g].sum_i = z[g].sum_w = z[g].sum_h = z[g].sum_tf = z[g].sum_tm = z[g].sum_fr = z[g].stuck_count = D{};
        }
        for (long a = 0; a < aircraft_per_sample; ++a) {
            for (long j = 0; j < s.steps_per_aircraft; ++j) {
                ++n;
                const double t_step = static_cast<double>(n) * s.dt;  // section 7: step n runs at t = n dt
                const double cmd_m = s.tau * detail::deg2rad(detail::command_deg_inline(s.sequence, t_step));
                for (int g = 0; g < G; ++g) detail::step<W, kFull>(s, z[g], n, cmd_m);
            }
            if (case_b) {
                for (int g = 0; g < G; ++g) detail::aircraft_update<W, kFull>(s, z[g]);
            }
        }
        const double t = static_cast<double>(n) * s.dt;
        const double cmd = command_deg(s.sequence, t);
        for (int g = 0; g < G; ++g) {
            Lanes<W>& zg = z[g];
            for (int l = 0; l < W; ++l) {
                SimResult& r = *out[g * W + l];
                Sample& smp = r.samples[static_cast<std::size_t>(k)];
                smp.t_s = t;
                smp.current_a = detail::lane(zg.sum_i, l) * inv_steps;
                smp.speed_rad_s = detail::lane(zg.sum_w, l) * inv_steps;
                smp.theta_m_rad = detail::lane(zg.th, l);
                smp.hinge_moment_nm = detail::lane(zg.sum_h, l) * inv_steps;
                smp.command_deg = cmd;
                if (!std::isfinite(smp.current_a) || !std::isfinite(smp.speed_rad_s) ||
                    !std::isfinite(smp.theta_m_rad) || !std::isfinite(smp.hinge_moment_nm)) {
                    r.finite = false;
                }
                if (record_truth) {
                    SampleTruth& tr = r.truth[static_cast<std::size_t>(k)];
                    tr.friction_torque_nm = detail::lane(zg.sum_tf, l) * inv_steps;
                    tr.motor_torque_nm = detail::lane(zg.sum_tm, l) * inv_steps;
                    tr.load_torque_nm = detail::lane(zg.sum_fr, l) * inv_steps;
                    tr.stuck_all_period = detail::lane(zg.stuck_count, l) == static_cast<double>(s.steps_per_sample);
                }
            }
        }
    }
    if constexpr (kFull) {
        for (int g = 0; g < G; ++g) {
            Lanes<W>& zg = z[g];
            for (int l = 0; l < W; ++l) {
                EnergyAccount& e = out[g * W + l]->energy;
                e.electrical_in_j = detail::lane(zg.e_in, l);
                e.copper_loss_j = detail::lane(zg.e_cu, l);
                e.friction_work_j = detail::lane(zg.e_fr, l);
                e.load_work_j = detail::lane(zg.e_load, l);
                e.saturation_loss_j = detail::lane(zg.e_sat, l);
                e.stop_loss_j = detail::lane(zg.e_stop, l);
                e.stored_start_j = 0.0;
                const double i = detail::lane(zg.i, l);
                const double w = detail::lane(zg.w, l);
                e.stored_end_j = 0.5 * s.l * i * i + 0.5 * s.j * w * w;
            }
        }
    }
}

/// Measurement effects (sensor errors) act on the reported samples only.
void apply_sensor_effects(std::vector<Sample>& samples, const Effects& fx) {
    if (fx.current_gain_error == 0.0 && fx.hinge_offset_nm == 0.0) return;
    for (auto& smp : samples) {
        smp.current_a *= 1.0 + fx.current_gain_error;
        smp.hinge_moment_nm += fx.hinge_offset_nm;
    }
}

bool needs_full(const SimConfig& c) {
    return c.record_truth || c.params.effects.any() || !c.params.terms.empty();
}

template <int W, int G>
void run_group(const SimConfig* configs[W * G], SimResult* out[W * G]) {
    const Shared s = detail::make_shared(*configs[0]);
    auto z = std::make_unique<Lanes<W>[]>(G);
    for (int l = 0; l < W * G; ++l) load_lane(z[l / W], l % W, configs[l]->params);
    bool full = false;
    bool truth = false;
    for (int l = 0; l < W * G; ++l) {
        full = full || needs_full(*configs[l]);
        truth = truth || configs[l]->record_truth;
    }
    if (full) {
        run_lanes<W, G, true>(s, z.get(), out, truth);
    } else {
        run_lanes<W, G, false>(s, z.get(), out, false);
    }
    for (int l = 0; l < W * G; ++l) {
        if (!configs[l]->record_truth) {
            out[l]->truth.clear();
            out[l]->energy = EnergyAccount{};
        }
        detail::apply_sensor_terms(out[l]->samples, configs[l]->params.terms, configs[l]->params.tau);
        apply_sensor_effects(out[l]->samples, configs[l]->params.effects);
        apply_noise(out[l]->samples, configs[l]->noise, configs[l]->seed);
    }
}

std::string batch_mismatch(const SimConfig& a, const SimConfig& b) {
    if (a.load_case != b.load_case) return "load_case";
    if (a.sequence != b.sequence) return "sequence";
    if (nlohmann::json(a.params.to_json().value("terms", nlohmann::json())) !=
        nlohmann::json(b.params.to_json().value("terms", nlohmann::json()))) {
        return "params.terms";
    }
    const double da = a.duration_s > 0 ? a.duration_s : default_duration_s(a.sequence);
    const double db = b.duration_s > 0 ? b.duration_s : default_duration_s(b.sequence);
    if (da != db) return "duration_s";
    nlohmann::json ja = a.params.to_json();
    nlohmann::json jb = b.params.to_json();
    for (const char* health : {"fdj_nm", "fsj_nm", "eta_o", "eta_a"}) {
        ja.erase(health);
        jb.erase(health);
    }
    for (const auto& [key, value] : ja.items()) {
        if (jb[key] != value) return "params." + key;
    }
    return {};
}

}  // namespace

SimResult simulate(const SimConfig& config) {
    SimResult result;
    const SimConfig* cfg[1] = {&config};
    SimResult* out[1] = {&result};
    run_group<1, 1>(cfg, out);
    return result;
}

std::vector<SimResult> simulate_batch(const std::vector<SimConfig>& configs, unsigned threads) {
    std::vector<SimResult> results(configs.size());
    if (configs.empty()) return results;
    for (std::size_t i = 1; i < configs.size(); ++i) {
        const std::string field = batch_mismatch(configs[0], configs[i]);
        if (!field.empty()) {
            throw SimError("simulate_batch: config " + std::to_string(i) + " differs from config 0 in " + field +
                           "; a batch may differ only in FDJ, FSJ, eta_O, eta_A, noise and seed");
        }
    }
    configs[0].params.validate();
    for (const auto& c : configs) c.params.validate();
    // Terms (term_hook.hpp) are evaluated on the scalar path only.
    if (!configs[0].params.terms.empty()) {
        for (std::size_t i = 0; i < configs.size(); ++i) results[i] = simulate(configs[i]);
        return results;
    }
    (void)detail::make_shared(configs[0]);  // duration and step counts: throw here, not in a worker
    constexpr int W = kBatchLanes * kBatchGroups;
    const std::size_t groups = (configs.size() + W - 1) / W;
    std::atomic<std::size_t> next{0};
    std::exception_ptr failure;
    std::mutex failure_mutex;
    auto work = [&] {
        std::vector<SimResult> pad(W);
        for (std::size_t g = next.fetch_add(1); g < groups; g = next.fetch_add(1)) {
            const SimConfig* cfg[W];
            SimResult* out[W];
            for (int l = 0; l < W; ++l) {
                const std::size_t idx = g * W + static_cast<std::size_t>(l);
                if (idx < configs.size()) {
                    cfg[l] = &configs[idx];
                    out[l] = &results[idx];
                } else {  // pad the last group with copies of its first lane, then discard them
                    cfg[l] = &configs[g * W];
                    out[l] = &pad[static_cast<std::size_t>(l)];
                }
            }
            run_group<kBatchLanes, kBatchGroups>(cfg, out);
        }
    };
    auto worker = [&] {
        try {
            work();
        } catch (...) {  // an exception must not leave a thread: keep the first, rethrow after the join
            const std::lock_guard<std::mutex> lock(failure_mutex);
            if (!failure) failure = std::current_exception();
            next = groups;
        }
    };
    const unsigned n_threads = std::max(1u, std::min<unsigned>(threads, static_cast<unsigned>(groups)));
    std::vector<std::thread> pool;
    for (unsigned i = 1; i < n_threads; ++i) pool.emplace_back(worker);
    worker();
    for (auto& th : pool) th.join();
    if (failure) std::rethrow_exception(failure);
    return results;
}

namespace {
/// Uniform in (0, 1) from the top 53 bits of mt19937_64, identical on every standard library.
double uniform_open(std::mt19937_64& rng) {
    return (static_cast<double>(rng() >> 11) + 0.5) * (1.0 / 9007199254740992.0);
}
/// Standard normal by Box-Muller on top of mt19937_64 (one draw per call, the sine branch dropped).
double normal(std::mt19937_64& rng) {
    const double u1 = uniform_open(rng);
    const double u2 = uniform_open(rng);
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}
double quantise(double v, double step) { return std::round(v / step) * step; }
}  // namespace

void apply_noise(std::vector<Sample>& samples, NoiseProfile profile, std::uint64_t seed) {
    if (profile == NoiseProfile::None) return;
    std::mt19937_64 rng(seed);
    for (auto& smp : samples) {
        smp.current_a = quantise(smp.current_a + kTypicalSigmaCurrentA * normal(rng), kCurrentResolutionA);
        smp.speed_rad_s = quantise(smp.speed_rad_s + kTypicalSigmaSpeedRadS * normal(rng), kSpeedResolutionRadS);
        smp.theta_m_rad = quantise(smp.theta_m_rad + kTypicalSigmaThetaRad * normal(rng), kThetaResolutionRad);
        smp.hinge_moment_nm = quantise(smp.hinge_moment_nm + kTypicalSigmaHingeNm * normal(rng), kHingeResolutionNm);
    }
}

}  // namespace emadiag::sim
