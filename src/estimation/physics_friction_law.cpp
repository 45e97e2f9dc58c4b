#include "estimation/physics_friction_law.hpp"

#include "emadiag/sim/ema_params.hpp"
#include "estimation/health_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace emadiag {
namespace {
constexpr double kCoveredFraction = 0.95;
constexpr double kNegligibleFraction = 1e-6;  // one part is negligible: use the other's exact limit
constexpr int kBisectionSteps = 60;
}  // namespace

double load_coefficient_aiding(double eta_o, double tau) {
    return sim::load_coefficient_aiding(sim::eta_a_from_eta_o(eta_o, tau));  // eq. (5), aiding, with eq. (4)
}

double eta_a_derivative(double eta_o, double tau) {
    // eq. (4): eta_A = (2 tau^2 eta_O - tau^2 + tau) / (tau^2 eta_O + tau - eta_O + 1) = N / D
    const double t2 = tau * tau;
    const double num = 2 * t2 * eta_o - t2 + tau;
    const double den = t2 * eta_o + tau - eta_o + 1;
    return (2 * t2 * den - num * (t2 - 1)) / (den * den);
}

double eta_a_derivative_central(double eta_o, double tau, double h) {
    return (sim::eta_a_from_eta_o(eta_o + h, tau) - sim::eta_a_from_eta_o(eta_o - h, tau)) / (2 * h);
}

LoadCoefficientPrior load_coefficient_prior(double tau) {
    LoadCoefficientPrior p;
    const double eta_a_mid = 0.5 * (kPriorEtaAMin + kPriorEtaAMax);
    p.eta_o_mid = sim::eta_o_from_eta_a(eta_a_mid, tau);
    p.c_opp_mid = load_coefficient_opposing(p.eta_o_mid);
    p.c_aid_mid = load_coefficient_aiding(p.eta_o_mid, tau);
    const double eo_lo = sim::eta_o_from_eta_a(kPriorEtaAMin, tau);
    const double eo_hi = sim::eta_o_from_eta_a(kPriorEtaAMax, tau);
    const double opp_half = 0.5 * std::abs(load_coefficient_opposing(eo_lo) - load_coefficient_opposing(eo_hi));
    const double aid_half = 0.5 * (kPriorEtaAMax - kPriorEtaAMin);
    p.c_half_width = std::max(opp_half, aid_half);
    return p;
}

double uniform_equivalent_se(double half_width) { return kCoveredFraction * half_width / kZ95; }

double uniform_plus_gaussian_se(double half_width, double gaussian_se) {
    const double h = std::abs(half_width), sigma = std::abs(gaussian_se);
    if (sigma <= kNegligibleFraction * h) return uniform_equivalent_se(h);
    if (h <= kNegligibleFraction * sigma) return sigma;
    auto phi_antiderivative = [](double x) {
        const double cdf = 0.5 * std::erfc(-x / std::numbers::sqrt2);
        const double pdf = std::exp(-0.5 * x * x) / std::sqrt(2.0 * std::numbers::pi);
        return x * cdf + pdf;
    };
    auto coverage = [&](double q) {
        return sigma / (2.0 * h) *
               (phi_antiderivative((q + h) / sigma) - phi_antiderivative((q - h) / sigma) -
                phi_antiderivative((h - q) / sigma) + phi_antiderivative(-(q + h) / sigma));
    };
    // coverage is increasing in q; the 95 % point lies in [0, h + 1.96 sigma].
    double lo = 0.0, hi = h + kZ95 * sigma;
    for (int it = 0; it < kBisectionSteps; ++it) {
        const double mid = 0.5 * (lo + hi);
        (coverage(mid) < kCoveredFraction ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi) / kZ95;
}

}  // namespace emadiag
