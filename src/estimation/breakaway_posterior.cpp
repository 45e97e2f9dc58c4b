#include "estimation/breakaway.hpp"

#include "estimation/health_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

namespace emadiag {

std::pair<double, double> mixture_moments(const std::vector<MixtureComponent>& mix) {
    double w = 0, m1 = 0, m2 = 0;
    for (const auto& c : mix) {
        w += c.weight;
        m1 += c.weight * c.mean;
        m2 += c.weight * (c.mean * c.mean + c.sd * c.sd);
    }
    if (!(w > 0)) return {0.0, 0.0};
    const double mean = m1 / w;
    return {mean, std::sqrt(std::max(0.0, m2 / w - mean * mean))};
}

PosteriorSummary product_posterior(const std::vector<std::vector<MixtureComponent>>& mixes, const HealthRange& band,
                                   double uniform_half_width) {
    constexpr double kGridSpanSd = 6.0;
    constexpr int kGridPoints = 4000;
    constexpr double kMass = 0.95;
    constexpr double kNegligibleWeight = 1e-12;  // relative to a look's heaviest component
    PosteriorSummary out;
    // The grid spans the components that carry weight: a profile point far from the best t_b can
    // map to a wild value (g0 grows as the slip span shrinks) with a weight of exp(-1000).
    double lo = std::numeric_limits<double>::infinity(), hi = -lo, finest = lo;
    for (const auto& mix : mixes) {
        double heaviest = 0;
        for (const auto& c : mix) heaviest = std::max(heaviest, c.weight);
        for (const auto& c : mix) {
            if (c.weight < kNegligibleWeight * heaviest) continue;
            lo = std::min(lo, c.mean - kGridSpanSd * c.sd);
            hi = std::max(hi, c.mean + kGridSpanSd * c.sd);
            finest = std::min(finest, c.sd);
        }
    }
    if (mixes.empty() || !(hi > lo) || !(finest > 0)) {
        if (!mixes.empty()) std::tie(out.mean, out.sd) = mixture_moments(mixes.front());
        out.se95 = out.sd;
        return out;
    }
    const double step = (hi - lo) / kGridPoints;
    const auto grid = [&](int k) { return lo + k * step; };
    std::vector<double> log_density(kGridPoints + 1, 0.0), p(kGridPoints + 1);
    for (const auto& mix : mixes) {
        std::fill(p.begin(), p.end(), 0.0);
        for (const auto& c : mix) {  // each component only over its own +/- kGridSpanSd
            const double f0 = std::floor((c.mean - kGridSpanSd * c.sd - lo) / step);
            const double f1 = std::ceil((c.mean + kGridSpanSd * c.sd - lo) / step);
            if (!(f1 >= 0.0 && f0 <= kGridPoints)) continue;  // off the grid (or not finite)
            const int k0 = static_cast<int>(std::max(0.0, f0));
            const int k1 = static_cast<int>(std::min(static_cast<double>(kGridPoints), f1));
            for (int k = k0; k <= k1; ++k) {
                const double z = (grid(k) - c.mean) / c.sd;
                p[static_cast<std::size_t>(k)] += c.weight / c.sd * std::exp(-0.5 * z * z);
            }
        }
        for (std::size_t k = 0; k < p.size(); ++k) {
            log_density[k] += p[k] > 0 ? std::log(p[k]) : -std::numeric_limits<double>::infinity();
        }
    }
    const double top = *std::max_element(log_density.begin(), log_density.end());
    if (!std::isfinite(top)) {  // the looks do not overlap at all: fall back to the first
        std::tie(out.mean, out.sd) = mixture_moments(mixes.front());
        out.se95 = out.sd;
        return out;
    }
    for (std::size_t k = 0; k < p.size(); ++k) p[k] = std::exp(log_density[k] - top);
    // The value is the measured quantity plus an independent uniform error of +/- h: the
    // density is the product's convolved with that box (a running mean over 2 h). The grid is
    // widened by h on both sides first.
    const int box = static_cast<int>(std::lround(uniform_half_width / step));
    std::vector<double> conv(p.size() + 2 * static_cast<std::size_t>(box), 0.0);
    if (box > 0) {
        std::vector<double> prefix(p.size() + 1, 0.0);
        for (std::size_t k = 0; k < p.size(); ++k) prefix[k + 1] = prefix[k] + p[k];
        for (std::size_t j = 0; j < conv.size(); ++j) {  // conv[j] stands at grid(j - box)
            const long c0 = static_cast<long>(j) - 2 * box, c1 = static_cast<long>(j);  // p indices [c0, c1]
            const long a0 = std::max(0L, c0), a1 = std::min(static_cast<long>(p.size()) - 1, c1);
            conv[j] = a1 >= a0 ? prefix[static_cast<std::size_t>(a1 + 1)] - prefix[static_cast<std::size_t>(a0)] : 0.0;
        }
    } else {
        conv = p;
    }
    p = std::move(conv);
    const double x0 = lo - box * step;
    const auto at = [&](std::size_t j) { return x0 + static_cast<double>(j) * step; };
    double w = 0, m1 = 0, m2 = 0;
    for (std::size_t j = 0; j < p.size(); ++j) {
        const double x = at(j);
        p[j] *= x >= band.lo && x <= band.hi ? 1.0 : kOutOfBandPrior;
        w += p[j];
        m1 += p[j] * x;
        m2 += p[j] * x * x;
    }
    out.mean = m1 / w;
    out.sd = std::sqrt(std::max(0.0, m2 / w - out.mean * out.mean));
    // Smallest half-width h with kMass of the posterior inside mean +/- h (bisection on h).
    auto mass_within = [&](double h) {
        double m = 0;
        for (std::size_t j = 0; j < p.size(); ++j) {
            if (std::abs(at(j) - out.mean) <= h) m += p[j];
        }
        return m / w;
    };
    double h_lo = 0, h_hi = hi - lo + 2 * box * step;
    for (int it = 0; it < 40; ++it) {
        const double h = 0.5 * (h_lo + h_hi);
        (mass_within(h) >= kMass ? h_hi : h_lo) = h;
    }
    out.se95 = std::max(h_hi, step) / kZ95;
    return out;
}

}  // namespace emadiag
