#include "research/physics_calibration.hpp"

#include "core/emadiag_error.hpp"
#include "core/sim_run.hpp"
#include "estimation/dataset.hpp"
#include "estimation/health_estimate.hpp"
#include "estimation/physics_estimator.hpp"
#include "estimation/physics_friction_law.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <map>
#include <random>
#include <sstream>

namespace emadiag {
namespace {
constexpr std::uint64_t kNoiseSeedStride = 1000003;
using sim::kCaseAHingeNm;  // ema-reference.md section 4
constexpr double kOnePercent = 0.01, kThreePercent = 0.03;
}  // namespace

const ParameterScore& CalibrationResult::score(const std::string& name) const {
    for (const auto& s : scores) {
        if (s.name == name) return s;
    }
    throw EmadiagError("no score for parameter '" + name + "'");
}

CalibrationResult evaluate_physics(const CalibrationSpec& spec) {
    const auto start = std::chrono::steady_clock::now();
    CalibrationResult out;
    out.spec = spec;
    std::mt19937_64 rng(spec.seed);
    std::vector<sim::SimConfig> configs;
    std::vector<HealthLabels> labels;
    for (int i = 0; i < spec.count; ++i) {
        sim::SimConfig c;
        c.load_case = spec.load_case;
        c.sequence = spec.sequence;
        c.noise = spec.noise;
        c.seed = spec.seed * kNoiseSeedStride + static_cast<std::uint64_t>(i);
        const HealthLabels h = draw_health_labels(rng, c.params.tau);
        h.apply_to(c.params);
        configs.push_back(c);
        labels.push_back(h);
    }
    const auto results = sim::simulate_batch(configs, std::max(1u, spec.threads));
    std::map<std::string, ParameterScore> acc;
    for (const char* p : kHealthParameterNames) acc[p].name = p;
    for (std::size_t i = 0; i < results.size(); ++i) {
        HealthEstimate est;
        try {
            est = estimate_physics(check_run(make_run(configs[i], results[i])));
        } catch (const std::exception& e) {
            ++out.failures;
            out.failure_messages.push_back("run " + std::to_string(i) + ": " + e.what());
            continue;
        }
        for (const auto& p : est.parameters) {
            auto& s = acc[p.name];
            if (!p.value) {
                ++s.not_estimated;
                continue;
            }
            const double truth = labels[i].get(p.name);
            const double err = *p.value - truth;
            const HealthRange range = health_range(p.name);
            ++s.estimated;
            s.covered += std::abs(err) <= kZ95 * p.std_error ? 1 : 0;
            s.mse_normalised += std::pow(err / (range.hi - range.lo), 2);
            s.max_rel_error = std::max(s.max_rel_error, std::abs(err) / std::abs(truth));
            s.mean_rel_error += std::abs(err) / std::abs(truth);
            s.within_1pct += std::abs(err) <= kOnePercent * std::abs(truth) ? 1 : 0;
            s.within_3pct += std::abs(err) <= kThreePercent * std::abs(truth) ? 1 : 0;
            s.mean_z2 += p.std_error > 0 ? std::pow(err / p.std_error, 2) : (err == 0 ? 0.0 : INFINITY);
        }
    }
    for (const char* p : kHealthParameterNames) {
        auto s = acc[p];
        if (s.estimated > 0) {
            s.mse_normalised /= s.estimated;
            s.mean_rel_error /= s.estimated;
            s.mean_z2 /= s.estimated;
        }
        out.scores.push_back(s);
    }
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return out;
}

std::string format_calibration(const CalibrationResult& r) {
    std::ostringstream os;
    os << "case " << sim::to_string(r.spec.load_case) << ", " << sim::to_string(r.spec.sequence) << ", noise "
       << sim::to_string(r.spec.noise) << ", " << r.spec.count << " runs, seed " << r.spec.seed;
    if (r.failures) os << ", " << r.failures << " FAILED";
    os << '\n';
    for (const auto& s : r.scores) {
        os << "  " << std::left << std::setw(7) << s.name;
        if (s.estimated == 0) {
            os << " not estimated in " << s.not_estimated << " runs\n";
            continue;
        }
        os << std::setprecision(4) << " coverage " << std::setw(6) << 100.0 * s.coverage() << " %  (" << s.covered << "/"
           << s.estimated << ")  normalised MSE " << std::setw(10) << s.mse_normalised << "  rel. error mean "
           << std::setw(9) << 100.0 * s.mean_rel_error << " % max " << std::setw(9) << 100.0 * s.max_rel_error
           << " %  within 1 %: " << s.within_1pct << "/" << s.estimated << ", 3 %: " << s.within_3pct << "/"
           << s.estimated << "  mean (err/se)^2 " << s.mean_z2;
        if (s.not_estimated) os << "  (not identifiable in " << s.not_estimated << ")";
        os << '\n';
    }
    for (const auto& m : r.failure_messages) os << "  failure: " << m << '\n';
    return os.str();
}

double case_a_fdj_floor_normalised(double tau, int grid) {
    // s = FDJ + c x with c the load coefficient (the opposing and aiding ones nearly coincide in
    // case A, x = 5 N m / tau). FDJ uniform, eta_A uniform. E[Var(FDJ | s)] by binning s finely.
    const HealthRange fdj = health_range(kParamFdj);
    const double x = kCaseAHingeNm / tau;
    const int n = std::max(grid, 10);
    std::vector<std::pair<double, double>> pts;  // (s, fdj)
    pts.reserve(static_cast<std::size_t>(n) * static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
        const double f = fdj.lo + (i + 0.5) / n * (fdj.hi - fdj.lo);
        for (int k = 0; k < n; ++k) {
            const double eta_a = kPriorEtaAMin + (k + 0.5) / n * (kPriorEtaAMax - kPriorEtaAMin);
            pts.emplace_back(f + sim::load_coefficient_aiding(eta_a) * x, f);
        }
    }
    std::sort(pts.begin(), pts.end());
    // Bins of equal count along s.
    const std::size_t per_bin = static_cast<std::size_t>(n) / 4 + 1;
    double total = 0;
    for (std::size_t b = 0; b < pts.size(); b += per_bin) {
        const std::size_t e = std::min(pts.size(), b + per_bin);
        double m = 0;
        for (std::size_t i = b; i < e; ++i) m += pts[i].second;
        m /= static_cast<double>(e - b);
        for (std::size_t i = b; i < e; ++i) total += std::pow(pts[i].second - m, 2);
    }
    return total / static_cast<double>(pts.size()) / std::pow(fdj.hi - fdj.lo, 2);
}

}  // namespace emadiag
