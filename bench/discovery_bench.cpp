// Discovery on seeded runs (docs/discovery.md "Figures"): N DYN case B runs per true effect with
// random magnitudes, plus clean runs; prints the confusion matrix (true effect vs the first effect
// discovered), the coefficient errors, the error ratios before/after, and the false discoveries.
// Spall centres are drawn inside the surface angles a DYN case B run visits (-11.9 to 3.4 deg): a
// spall elsewhere leaves no trace in the run and cannot be found.
// Usage: discovery_bench [runs_per_effect=6] [seed=11] [noise=typical|none] [effects=all|none,viscous,...]
#include "core/sim_run.hpp"
#include "discovery/candidate_effect.hpp"
#include "discovery/discovery.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <random>
#include <string>
#include <vector>

namespace {

using emadiag::discovery::DiscoveryReport;

/// Uniform on [lo, hi) from the top 53 bits (the same on every standard library).
double uniform(std::mt19937_64& g, double lo, double hi) {
    return lo + (hi - lo) * static_cast<double>(g() >> 11) * 0x1.0p-53;
}

struct Truth {
    std::string kind;  ///< discovery effect name, or "none"
    std::vector<std::pair<std::string, double>> effects;
    std::string key;   ///< the sim effect whose value is compared
    double value = 0;
};

Truth draw(const std::string& kind, std::mt19937_64& g) {
    Truth t;
    t.kind = kind;
    const double sign = uniform(g, 0, 1) < 0.5 ? -1.0 : 1.0;
    if (kind == "viscous") {
        t.effects = {{"viscous", uniform(g, 2e-5, 1e-4)}};
    } else if (kind == "stribeck") {
        t.effects = {{"stribeck_amplitude", uniform(g, 0.03, 0.1)}, {"stribeck_speed", uniform(g, 30, 100)}};
    } else if (kind == "spall") {
        t.effects = {{"spall_amplitude", uniform(g, 0.03, 0.1)}, {"spall_center", uniform(g, -10, 2)},
                     {"spall_width", uniform(g, 0.5, 2.0)}};
    } else if (kind == "ripple") {
        t.effects = {{"ripple_amplitude", uniform(g, 0.03, 0.1)}, {"ripple_periods", 6.0}};
    } else if (kind == "current_gain_error") {
        t.effects = {{"current_gain_error", sign * uniform(g, 0.02, 0.06)}};
    } else if (kind == "hinge_offset") {
        t.effects = {{"hinge_offset", sign * uniform(g, 40, 150)}};
    } else if (kind == "inertia") {
        t.effects = {{"true_inertia", emadiag::sim::EmaParams{}.j_kgm2 * uniform(g, 1.1, 1.3)}};
    }
    if (!t.effects.empty()) {
        t.key = t.effects.front().first;
        t.value = t.effects.front().second;
    }
    return t;
}

double median(std::vector<double> v) {
    if (v.empty()) return NAN;
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

int main(int argc, char** argv) {
    const int runs = argc > 1 ? std::stoi(argv[1]) : 6;
    const std::uint64_t seed = argc > 2 ? std::stoull(argv[2]) : 11;
    const std::string noise = argc > 3 ? argv[3] : "typical";
    std::printf("discovery_bench: %d DYN case B runs per effect, seed %llu, noise %s\n", runs,
                static_cast<unsigned long long>(seed), noise.c_str());
    std::mt19937_64 g(seed);
    std::vector<std::string> kinds = {"none",   "viscous",            "stribeck",     "spall",
                                      "ripple", "current_gain_error", "hinge_offset", "inertia"};
    if (argc > 4 && std::string(argv[4]) != "all") {
        kinds.clear();
        std::string list = argv[4];
        for (std::size_t a = 0; a <= list.size();) {
            const std::size_t b = std::min(list.find(',', a), list.size());
            kinds.push_back(list.substr(a, b - a));
            a = b + 1;
        }
    }
    std::vector<std::string> columns = {"none",   "viscous",            "stribeck",     "spall",
                                        "ripple", "current_gain_error", "hinge_offset", "inertia"};
    columns.push_back("error");
    std::map<std::string, std::map<std::string, int>> confusion;
    std::map<std::string, std::vector<double>> coef_err, ratio_i, ratio_t, ratio_tw;
    std::map<std::string, int> extra;
    std::vector<double> area_err;  // Stribeck amplitude x speed  // further effects added after the first
    std::uint64_t run_seed = seed * 1000;
    for (const auto& kind : kinds) {
        for (int r = 0; r < runs; ++r) {
            const Truth t = draw(kind, g);
            emadiag::sim::SimConfig c;
            c.load_case = emadiag::sim::LoadCase::B;
            c.sequence = emadiag::sim::Sequence::Dyn;
            c.noise = emadiag::sim::parse_noise(noise);
            c.seed = ++run_seed;
            for (const auto& [k, v] : t.effects) c.params.effects.set(k, v);
            const auto run = emadiag::make_run(c, emadiag::sim::simulate(c));
            std::string found = "error";
            try {
                const DiscoveryReport rep = emadiag::discovery::discover(run);
                const auto added = rep.added_effects();
                found = added.empty() ? "none" : added.front();
                if (added.size() > 1) ++extra[kind];
                const auto& m = rep.model;
                if (!added.empty()) {
                    ratio_i[kind].push_back(m.error_before.current_rms_a / m.error_after.current_rms_a);
                    ratio_t[kind].push_back(m.error_before.residual_torque_rms_nm / m.error_after.residual_torque_rms_nm);
                    ratio_tw[kind].push_back(m.error_before.residual_torque_window_rms_nm /
                                             m.error_after.residual_torque_window_rms_nm);
                }
                std::string fitted = "-";
                if (found == kind && !t.key.empty()) {
                    const double v = rep.term_value(t.key).value_or(NAN);
                    coef_err[kind].push_back(std::abs(v - t.value) / std::abs(t.value));
                    if (kind == "stribeck") {
                        // The well-determined combination: the extra friction integrated over speed,
                        // amplitude x w_s x sqrt(pi).
                        const double area = v * rep.term_value("stribeck_speed").value_or(NAN);
                        const double true_area = t.value * t.effects[1].second;
                        area_err.push_back(std::abs(area - true_area) / true_area);
                    }
                    char b[64];
                    std::snprintf(b, sizeof b, "%.4g", v);
                    fitted = b;
                }
                std::printf("  seed %llu true %-18s %s=%-10.4g found %-18s fitted %-10s before I %.4f A T_R %.4f/%.4f N m, "
                            "after I %.4f A T_R %.4f/%.4f N m\n",
                            static_cast<unsigned long long>(c.seed), kind.c_str(), t.key.empty() ? "-" : t.key.c_str(),
                            t.value, (added.empty() ? std::string("none") : [&] {
                                std::string s;
                                for (const auto& a : added) s += (s.empty() ? "" : "+") + a;
                                return s;
                            }()).c_str(),
                            fitted.c_str(), m.error_before.current_rms_a, m.error_before.residual_torque_rms_nm,
                            m.error_before.residual_torque_window_rms_nm, m.error_after.current_rms_a,
                            m.error_after.residual_torque_rms_nm, m.error_after.residual_torque_window_rms_nm);
            } catch (const std::exception& e) {
                std::printf("  seed %llu true %s: error %s\n", static_cast<unsigned long long>(c.seed), kind.c_str(), e.what());
            }
            ++confusion[kind][found];
        }
    }
    std::printf("\nconfusion matrix (rows: true effect, columns: first effect discovered)\n%-19s", "");
    for (const auto& col : columns) std::printf(" %6.6s", col.c_str());
    std::printf("\n");
    for (const auto& kind : kinds) {
        std::printf("%-19s", kind.c_str());
        for (const auto& col : columns) std::printf(" %6d", confusion[kind][col]);
        std::printf("   (+%d runs with a further effect)\n", extra[kind]);
    }
    std::printf("\nper true effect: median |coefficient error| (relative, when named), median ratio before/after "
                "(current, T_R, T_R window means)\n");
    for (const auto& kind : kinds) {
        std::printf("  %-19s coef %6.3f (max %6.3f, n %zu)   ratio I %6.2f  T_R %6.2f  T_R window %6.2f\n", kind.c_str(),
                    median(coef_err[kind]),
                    coef_err[kind].empty() ? NAN : *std::max_element(coef_err[kind].begin(), coef_err[kind].end()),
                    coef_err[kind].size(), median(ratio_i[kind]), median(ratio_t[kind]), median(ratio_tw[kind]));
    }
    std::printf("  stribeck amplitude x w_s: median relative error %.3f (max %.3f, n %zu)\n", median(area_err),
                area_err.empty() ? NAN : *std::max_element(area_err.begin(), area_err.end()), area_err.size());
    if (std::find(kinds.begin(), kinds.end(), "none") != kinds.end()) {
        std::printf("false discoveries on clean runs: %d of %d\n", runs - confusion["none"]["none"], runs);
    }
    return 0;
}
