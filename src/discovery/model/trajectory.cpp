#include "discovery/model/trajectory.hpp"

#include "discovery/screening/effect_screen.hpp"
#include "discovery/screening/term_library.hpp"
#include "emadiag/sim/simulator.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <cstdio>
#include <sstream>

namespace emadiag::discovery {
namespace {

constexpr double kMadToSigma = 1.0 / 0.6745;

double mad_sigma_of_differences(const std::vector<double>& e) {
    if (e.size() < 3) return 0.0;
    std::vector<double> d;
    for (std::size_t k = 1; k < e.size(); ++k) d.push_back(std::abs(e[k] - e[k - 1]));
    std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
    return d[d.size() / 2] * kMadToSigma / std::sqrt(2.0);
}

double quantisation(double resolution) { return resolution / std::sqrt(12.0); }

std::vector<double> diff_of(const std::vector<double>& a, const std::vector<double>& b) {
    std::vector<double> e(a.size());
    for (std::size_t k = 0; k < a.size(); ++k) e[k] = a[k] - b[k];
    return e;
}

double rms(const std::vector<double>& e) {
    double s = 0;
    for (double v : e) s += v * v;
    return e.empty() ? 0.0 : std::sqrt(s / static_cast<double>(e.size()));
}

/// Window means of the torque residual over consecutive comparison samples, with the sample indices.
void torque_windows(const RunSignals& a, const RunSignals& b, const std::vector<char>& mask, std::vector<double>& means,
                    std::vector<std::vector<std::size_t>>& windows) {
    for (std::size_t k = 0; k < mask.size(); ++k) {
        if (!mask[k]) continue;
        if (windows.empty() || windows.back().size() == kScreenWindowSamples || windows.back().back() + 1 != k) {
            windows.emplace_back();
        }
        windows.back().push_back(k);
    }
    for (const auto& w : windows) {
        double s = 0;
        for (std::size_t k : w) s += a.residual_torque_nm[k] - b.residual_torque_nm[k];
        means.push_back(s / static_cast<double>(w.size()));
    }
}

double binned_variance_explained(const std::vector<double>& x, const std::vector<double>& y) {
    const std::size_t n = x.size();
    if (n < static_cast<std::size_t>(3 * kStructureBins)) return 0.0;
    std::vector<std::size_t> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return x[a] < x[b]; });
    const double mean = std::accumulate(y.begin(), y.end(), 0.0) / static_cast<double>(n);
    double total = 0;
    for (double v : y) total += (v - mean) * (v - mean);
    if (total <= 0) return 0.0;
    double between = 0;
    for (int b = 0; b < kStructureBins; ++b) {
        const std::size_t lo = n * static_cast<std::size_t>(b) / kStructureBins;
        const std::size_t hi = n * static_cast<std::size_t>(b + 1) / kStructureBins;
        double s = 0;
        for (std::size_t i = lo; i < hi; ++i) s += y[order[i]];
        const double m = s / static_cast<double>(hi - lo);
        between += static_cast<double>(hi - lo) * (m - mean) * (m - mean);
    }
    const double eta2 = between / total;
    // Adjusted for the bins (like adjusted R^2): 0 on average for a residual that does not depend on x.
    const double dof = static_cast<double>(kStructureBins - 1) / static_cast<double>(n - 1);
    return std::max(0.0, (eta2 - dof) / (1.0 - dof));
}

StructureReport channel_report(const std::string& name, const std::string& unit, const std::vector<double>& e,
                               double floor, const std::vector<std::pair<std::string, std::vector<double>>>& vars) {
    StructureReport r;
    r.channel = name;
    r.unit = unit;
    r.floor = floor;
    // The largest single value is left out of the test: one glitch (a window across a kink that the
    // comparison mask let through, 17 floors on clean seed 901194) is not structure, and structure
    // spans several values.
    std::size_t worst = 0;
    for (std::size_t k = 1; k < e.size(); ++k) {
        if (std::abs(e[k]) > std::abs(e[worst])) worst = k;
    }
    std::vector<double> kept;
    kept.reserve(e.size());
    for (std::size_t k = 0; k < e.size(); ++k) {
        if (k != worst || e.size() < 2) kept.push_back(e[k]);
    }
    r.n = kept.size();
    r.rms = rms(kept);
    if (e.size() >= 2) {
        r.excluded_index = worst;
        r.excluded_value = e[worst];
    }
    if (floor > 0 && !kept.empty()) {
        for (double v : kept) r.chi2 += (v / floor) * (v / floor);
        const double n = static_cast<double>(kept.size());
        r.z = (r.chi2 - n) / std::sqrt(2.0 * n);
        const double excess = name == "torque"  ? kStructureMinExcess
                              : name == "theta" ? kStructureMinExcessTheta
                                                : kStructureMinExcessTrajectory;
        r.significant = r.z > kStructureMinZ && r.rms >= excess * floor;
    }
    for (const auto& [vname, x] : vars) r.dependence.push_back({vname, binned_variance_explained(x, e)});
    std::stable_sort(r.dependence.begin(), r.dependence.end(),
                     [](const Dependence& a, const Dependence& b) { return a.variance_explained > b.variance_explained; });
    if (!r.dependence.empty()) {
        for (const auto& [vname, x] : vars) {
            if (vname == r.dependence.front().variable) r.x = x;
        }
        r.y = e;
    }
    return r;
}

}  // namespace

NoiseFloor noise_floor(const RunSignals& a, const RunSignals& b, const std::vector<char>& mask) {
    NoiseFloor f;
    f.current_a = std::max(mad_sigma_of_differences(diff_of(a.current_a, b.current_a)), quantisation(sim::kCurrentResolutionA));
    f.speed_rad_s = std::max(mad_sigma_of_differences(diff_of(a.speed_rad_s, b.speed_rad_s)),
                             quantisation(sim::kSpeedResolutionRadS));
    f.theta_rad = std::max(mad_sigma_of_differences(diff_of(a.theta_m_rad, b.theta_m_rad)),
                           quantisation(sim::kThetaResolutionRad));
    f.load_nm = std::max(mad_sigma_of_differences(diff_of(a.load_torque_nm, b.load_torque_nm)),
                         quantisation(sim::kHingeResolutionNm) / a.tau);
    std::vector<double> means;
    std::vector<std::vector<std::size_t>> windows;
    torque_windows(a, b, mask, means, windows);
    // Floor: the quantisation of the current alone, k_t 0.002 A / sqrt(12 n).
    f.torque_window_nm = std::max(mad_sigma_of_differences(means),
                                  a.k_t_nm_per_a * quantisation(sim::kCurrentResolutionA) /
                                      std::sqrt(static_cast<double>(kScreenWindowSamples)));
    return f;
}

TrajectoryError trajectory_error(const RunSignals& a, const RunSignals& b, const NoiseFloor& f) {
    TrajectoryError t;
    t.current_a = rms(diff_of(a.current_a, b.current_a));
    t.speed_rad_s = rms(diff_of(a.speed_rad_s, b.speed_rad_s));
    t.theta_rad = rms(diff_of(a.theta_m_rad, b.theta_m_rad));
    t.load_nm = rms(diff_of(a.load_torque_nm, b.load_torque_nm));
    auto sq = [](double v, double s) { return s > 0 ? (v / s) * (v / s) : 0.0; };
    t.cost = 0.25 * (sq(t.current_a, f.current_a) + sq(t.speed_rad_s, f.speed_rad_s) + sq(t.theta_rad, f.theta_rad) +
                     sq(t.load_nm, f.load_nm));
    return t;
}

std::vector<StructureReport> structure_reports(const RunSignals& a, const RunSignals& b, const std::vector<char>& mask,
                                               const NoiseFloor& f) {
    std::vector<StructureReport> out;
    // Variables per sample.
    const std::size_t n = a.size();
    std::vector<std::pair<std::string, std::vector<double>>> vars = {
        {"w", {}}, {"|w|", {}}, {"theta_u", {}}, {"|theta_u|", {}}, {"F_R", {}}, {"|F_R|", {}}, {"t", {}}, {"I", {}}, {"dw/dt", {}}};
    for (std::size_t k = 0; k < n; ++k) {
        const sim::TermInputs x = sample_inputs(a, k);
        const double v[] = {x.w, std::abs(x.w), x.theta_u_deg, std::abs(x.theta_u_deg), x.f_r, std::abs(x.f_r), x.t, x.i,
                            a.accel_rad_s2[k]};
        for (std::size_t j = 0; j < vars.size(); ++j) vars[j].second.push_back(v[j]);
    }
    // Torque residual, window means, with the window means of the variables.
    {
        std::vector<double> means;
        std::vector<std::vector<std::size_t>> windows;
        torque_windows(a, b, mask, means, windows);
        std::vector<std::pair<std::string, std::vector<double>>> wvars;
        for (const auto& [name, x] : vars) {
            std::vector<double> m;
            for (const auto& w : windows) {
                double s = 0;
                for (std::size_t k : w) s += x[k];
                m.push_back(s / static_cast<double>(w.size()));
            }
            wvars.emplace_back(name, m);
        }
        out.push_back(channel_report("torque", "N m", means, f.torque_window_nm, wvars));
    }
    out.push_back(channel_report("current", "A", diff_of(a.current_a, b.current_a), f.current_a, vars));
    out.push_back(channel_report("speed", "rad/s", diff_of(a.speed_rad_s, b.speed_rad_s), f.speed_rad_s, vars));
    out.push_back(channel_report("theta", "rad", diff_of(a.theta_m_rad, b.theta_m_rad), f.theta_rad, vars));
    out.push_back(channel_report("load", "N m", diff_of(a.load_torque_nm, b.load_torque_nm), f.load_nm, vars));
    return out;
}

namespace {
std::string fmt_floors(double v, double floor) {
    char b[32];
    std::snprintf(b, sizeof b, "%.3g", floor > 0 ? std::abs(v) / floor : 0.0);
    return b;
}
}  // namespace

std::string structure_test_text(const StructureReport& r) {
    std::ostringstream os;
    os.precision(3);
    os << "chi-square of " << r.n << (r.channel == "torque" ? " window means" : " samples")
       << (r.excluded_index ? " (the largest single value, " + fmt_floors(r.excluded_value, r.floor) + " floors, left out)" : std::string())
       << " against the noise floor "
       << r.floor << ' ' << r.unit << ": chi2 " << r.chi2 << ", z = " << r.z << " (threshold " << kStructureMinZ
       << "), RMS " << r.rms / std::max(r.floor, 1e-300) << " x the floor (threshold "
       << (r.channel == "torque"  ? kStructureMinExcess
           : r.channel == "theta" ? kStructureMinExcessTheta
                                  : kStructureMinExcessTrajectory)
       << ")";
    return os.str();
}

}  // namespace emadiag::discovery
