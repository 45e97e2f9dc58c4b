#include "emadiag/sim/simulator.hpp"

#include "emadiag/sim/sim_error.hpp"
#include "batch_kernels.hpp"
#include "simd_target.hpp"
#include "step_kernel.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cctype>
#include <cmath>
#include <random>
#include <mutex>
#include <thread>
#include <exception>

namespace emadiag::sim {

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

/// Measurement effects (sensor errors) act on the reported samples only.
void apply_sensor_effects(std::vector<Sample>& samples, const Effects& fx) {
    if (fx.current_gain_error == 0.0 && fx.hinge_offset_nm == 0.0) return;
    for (auto& smp : samples) {
        smp.current_a *= 1.0 + fx.current_gain_error;
        smp.hinge_moment_nm += fx.hinge_offset_nm;
    }
}

}  // namespace

void detail::finish_run(const SimConfig& config, SimResult& result) {
    if (!config.record_truth) {
        result.truth.clear();
        result.energy = EnergyAccount{};
    }
    detail::apply_sensor_terms(result.samples, config.params.terms, config.params.tau);
    apply_sensor_effects(result.samples, config.params.effects);
    apply_noise(result.samples, config.noise, config.seed);
}

namespace {

std::string batch_mismatch(const SimConfig& a, const SimConfig& b) {
    if (a.load_case != b.load_case) return "load_case";
    if (a.sequence != b.sequence) return "sequence";
    const double da = a.duration_s > 0 ? a.duration_s : default_duration_s(a.sequence);
    const double db = b.duration_s > 0 ? b.duration_s : default_duration_s(b.sequence);
    if (da != db) return "duration_s";
    nlohmann::json ja = a.params.to_json();
    nlohmann::json jb = b.params.to_json();
    // Per lane: health, terms, and the effects other than backlash (the true inertia among them).
    for (const char* lane_field : {"fdj_nm", "fsj_nm", "eta_o", "eta_a", "terms"}) {
        ja.erase(lane_field);
        jb.erase(lane_field);
    }
    if (a.params.effects.backlash_rad != b.params.effects.backlash_rad) return "params.effects.backlash";
    ja.erase("effects");
    jb.erase("effects");
    for (const auto& [key, value] : ja.items()) {
        if (jb[key] != value) return "params." + key;
    }
    return {};
}

}  // namespace

namespace {
std::atomic<std::uint64_t> g_scalar_runs{0}, g_batch_runs{0};
std::atomic<std::int64_t> g_scalar_ns{0}, g_batch_ns{0};

/// Adds the wall time of a call to a counter when it ends (also when it throws).
class CallTimer {
public:
    explicit CallTimer(std::atomic<std::int64_t>& ns) : ns_(ns), t0_(std::chrono::steady_clock::now()) {}
    ~CallTimer() { ns_ += std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - t0_).count(); }
    CallTimer(const CallTimer&) = delete;
    CallTimer& operator=(const CallTimer&) = delete;

private:
    std::atomic<std::int64_t>& ns_;
    std::chrono::steady_clock::time_point t0_;
};
}  // namespace

SimCounters sim_counters() {
    SimCounters c;
    c.scalar_runs = g_scalar_runs;
    c.scalar_s = static_cast<double>(g_scalar_ns) * 1e-9;
    c.batch_runs = g_batch_runs;
    c.batch_s = static_cast<double>(g_batch_ns) * 1e-9;
    return c;
}

SimResult simulate(const SimConfig& config) {
    const CallTimer timer(g_scalar_ns);
    ++g_scalar_runs;
    SimResult result;
    if (detail::batch_runs_scalar()) {  // EMADIAG_SIMD=scalar: the baseline build's copy
        const SimConfig* cfg[1] = {&config};
        SimResult* out[1] = {&result};
        detail::run_group<1, 1>(cfg, out);
    } else {  // the same step compiled for the chosen target (batch_kernels.cpp)
        detail::run_scalar(config, result);
    }
    return result;
}

std::vector<SimResult> simulate_batch(const std::vector<SimConfig>& configs, unsigned threads) {
    const CallTimer timer(g_batch_ns);
    g_batch_runs += configs.size();
    std::vector<SimResult> results(configs.size());
    if (configs.empty()) return results;
    for (std::size_t i = 1; i < configs.size(); ++i) {
        const std::string field = batch_mismatch(configs[0], configs[i]);
        if (!field.empty()) {
            throw SimError("simulate_batch: config " + std::to_string(i) + " differs from config 0 in " + field +
                           "; a batch may differ only in FDJ, FSJ, eta_O, eta_A, the effects other than backlash, the "
                           "terms, noise and seed");
        }
    }
    configs[0].params.validate();
    for (const auto& c : configs) c.params.validate();
    (void)detail::make_shared(configs[0]);  // duration and step counts: throw here, not in a worker
    // One group is the chosen target's lanes x groups simulations (1 on the scalar path). A batch
    // too small to give every thread full groups (a fit's Jacobian columns: 3 to 8) runs single
    // vectors instead (groups = 1), each filled before the next is started: a vector with 2 lanes
    // in use costs about what one with 8 does, so spreading 3 runs over two threads would double
    // the CPU time for no gain in wall time on a machine whose other core is busy.
    const bool scalar = detail::batch_runs_scalar();
    const detail::BatchShape shape = scalar ? detail::BatchShape{"scalar", 1, 1} : detail::batch_shape();
    const auto lanes = static_cast<std::size_t>(shape.lanes);
    const std::size_t thread_count = std::max(1u, threads);
    const bool small = !scalar && configs.size() < thread_count * lanes * static_cast<std::size_t>(shape.groups);
    const std::size_t width = scalar ? 1
                              : small ? lanes
                                      : lanes * static_cast<std::size_t>(shape.groups);
    const std::size_t kernel_width = small ? lanes : width;  // lanes beyond `width` are padding
    const std::size_t groups = (configs.size() + width - 1) / width;
    // Padding lanes copy config 0 without its effects and terms (backlash stays: it is shared), so
    // their lane-by-lane work (effects, terms) costs no library call; their results are discarded.
    SimConfig padding = configs[0];
    padding.params.terms.clear();
    const double backlash = padding.params.effects.backlash_rad;
    padding.params.effects = Effects{};
    padding.params.effects.backlash_rad = backlash;
    std::atomic<std::size_t> next{0};
    std::exception_ptr failure;
    std::mutex failure_mutex;
    auto work = [&] {
        std::vector<SimResult> pad(kernel_width);
        std::vector<const SimConfig*> cfg(kernel_width);
        std::vector<SimResult*> out(kernel_width);
        for (std::size_t g = next.fetch_add(1); g < groups; g = next.fetch_add(1)) {
            for (std::size_t l = 0; l < kernel_width; ++l) {
                const std::size_t idx = g * width + l;
                if (l < width && idx < configs.size()) {
                    cfg[l] = &configs[idx];
                    out[l] = &results[idx];
                } else {  // pad the group, then discard the padding's results
                    cfg[l] = &padding;
                    pad[l] = SimResult{};
                    out[l] = &pad[l];
                }
            }
            if (scalar) {
                detail::run_group<1, 1>(cfg.data(), out.data());
            } else if (small) {
                detail::run_batch_vector(cfg.data(), out.data());
            } else {
                detail::run_batch_group(cfg.data(), out.data());
            }
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
