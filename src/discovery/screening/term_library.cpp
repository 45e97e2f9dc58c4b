#include "discovery/screening/term_library.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>

namespace emadiag::discovery {
namespace {

using sim::Term;
using sim::TermBasis;
using sim::TermFactor;
using sim::TermSignal;

/// Periods scanned for the periodic bases, geometric.
constexpr double kSurfacePeriodMinDeg = 1.0, kSurfacePeriodMaxDeg = 40.0;
constexpr int kSurfacePeriods = 14;
constexpr double kMotorPeriodMinRad = 8.0, kMotorPeriodMaxRad = 250.0;
constexpr int kMotorPeriods = 16;
/// Bump centres every this many degrees over the visited surface angles, and the widths.
constexpr double kBumpStepDeg = 0.5;
constexpr double kBumpWidthsDeg[] = {0.5, 1.0, 2.0, 4.0};
/// Sub-points of a period over which a term that reads the motor angle is averaged.
constexpr int kMotorAngleSubpoints = 4;

TermFactor factor(TermBasis b, TermSignal s, double a = 0, double c = 0) { return TermFactor{b, s, a, c}; }
Term term_of(std::vector<TermFactor> f) {
    Term t;
    t.coefficient = 1.0;
    t.factors = std::move(f);
    return t;
}

std::vector<double> geometric(double lo, double hi, int n) {
    std::vector<double> v;
    for (int i = 0; i < n; ++i) v.push_back(lo * std::pow(hi / lo, static_cast<double>(i) / (n - 1)));
    return v;
}

bool reads_motor_angle(const Term& t) {
    return std::any_of(t.factors.begin(), t.factors.end(),
                       [](const TermFactor& f) { return f.signal == TermSignal::ThetaMotor; });
}

}  // namespace

sim::TermInputs sample_inputs(const RunSignals& s, std::size_t k) {
    sim::TermInputs x;
    x.w = s.speed_rad_s[k];
    x.theta_m = 0.5 * (s.theta_start_rad[k] + s.theta_m_rad[k]);
    x.theta_u_deg = x.theta_m / s.tau * 180.0 / std::numbers::pi;
    x.f_r = s.load_torque_nm[k];
    x.t = s.t_s[k] - 0.5 * s.sample_period_s;
    x.i = s.current_a[k];
    return x;
}

std::vector<TermFamily> generated_library(const RunSignals& s) {
    std::vector<TermFamily> lib;
    // Products: features per signal; monomials of one feature or two of different signals.
    const std::vector<std::vector<TermFactor>> features = {
        {factor(TermBasis::Identity, TermSignal::Speed), factor(TermBasis::Abs, TermSignal::Speed),
         factor(TermBasis::Square, TermSignal::Speed)},
        {factor(TermBasis::Identity, TermSignal::ThetaSurface), factor(TermBasis::Abs, TermSignal::ThetaSurface)},
        {factor(TermBasis::Identity, TermSignal::LoadTorque), factor(TermBasis::Abs, TermSignal::LoadTorque),
         factor(TermBasis::Square, TermSignal::LoadTorque)},
        {factor(TermBasis::Identity, TermSignal::Time)},
    };
    std::vector<std::vector<TermFactor>> monomials;
    for (std::size_t a = 0; a < features.size(); ++a) {
        for (const auto& fa : features[a]) {
            monomials.push_back({fa});
            for (std::size_t b = a + 1; b < features.size(); ++b) {
                for (const auto& fb : features[b]) monomials.push_back({fa, fb});
            }
        }
    }
    std::set<std::string> seen = {"1", "sgn(w)", "sgn(w)*abs(F_R)", "w"};  // in the model or the library
    const TermFactor sgn_w = factor(TermBasis::Sgn, TermSignal::Speed);
    for (const auto& m : monomials) {
        for (int friction = 0; friction < 2; ++friction) {
            std::vector<TermFactor> f = m;
            bool folded = false;
            if (friction) {
                // sgn(w) w = |w| and sgn(w) |w| = w; otherwise sgn(w) is a factor of its own.
                for (auto& x : f) {
                    if (x.signal == TermSignal::Speed && x.basis == TermBasis::Identity) {
                        x.basis = TermBasis::Abs;
                        folded = true;
                    } else if (x.signal == TermSignal::Speed && x.basis == TermBasis::Abs) {
                        x.basis = TermBasis::Identity;
                        folded = true;
                    }
                }
                if (!folded) f.insert(f.begin(), sgn_w);
            }
            Term t = term_of(f);
            const std::string text = t.basis_text();
            if (!seen.insert(text).second) continue;
            lib.push_back({text, {{t}}, 0, friction == 1 && !folded});  // sgn(w) a factor of its own
        }
    }
    // Periodic bases: sin and cos together (amplitude and phase), period scanned.
    auto periodic = [&](TermSignal sig, const std::vector<double>& periods, bool friction, const std::string& name) {
        TermFamily fam{name, {}, 1, friction};
        for (double p : periods) {
            std::vector<Term> block;
            for (TermBasis b : {TermBasis::Sin, TermBasis::Cos}) {
                std::vector<TermFactor> f;
                if (friction) f.push_back(sgn_w);
                f.push_back(factor(b, sig, p));
                block.push_back(term_of(f));
            }
            fam.shapes.push_back(block);
        }
        lib.push_back(fam);
    };
    const auto surface_periods = geometric(kSurfacePeriodMinDeg, kSurfacePeriodMaxDeg, kSurfacePeriods);
    const auto motor_periods = geometric(kMotorPeriodMinRad, kMotorPeriodMaxRad, kMotorPeriods);
    periodic(TermSignal::ThetaSurface, surface_periods, false, "sin/cos(theta_u, P)");
    periodic(TermSignal::ThetaSurface, surface_periods, true, "sgn(w)*sin/cos(theta_u, P)");
    periodic(TermSignal::ThetaMotor, motor_periods, false, "sin/cos(theta_m, P)");
    periodic(TermSignal::ThetaMotor, motor_periods, true, "sgn(w)*sin/cos(theta_m, P)");
    // Bumps over the visited surface angles (not friction: sgn(w) gauss is the library's spall).
    double lo = 0, hi = 0;
    bool any = false;
    for (std::size_t k = 0; k < s.size(); ++k) {
        if (!s.slipping[k]) continue;
        const double a = sample_inputs(s, k).theta_u_deg;
        lo = any ? std::min(lo, a) : a;
        hi = any ? std::max(hi, a) : a;
        any = true;
    }
    if (any) {
        TermFamily fam{"gauss(theta_u, c, s)", {}, 2};
        for (double c = std::ceil(lo / kBumpStepDeg) * kBumpStepDeg; c <= hi; c += kBumpStepDeg) {
            for (double w : kBumpWidthsDeg) {
                fam.shapes.push_back({term_of({factor(TermBasis::Gauss, TermSignal::ThetaSurface, c, w)})});
            }
        }
        if (!fam.shapes.empty()) lib.push_back(fam);
    }
    return lib;
}

std::size_t library_size(const std::vector<TermFamily>& lib) {
    std::size_t n = 0;
    for (const auto& f : lib) n += f.shapes.size();
    return n;
}

std::vector<double> term_signature(const RunSignals& s, const sim::Term& term) {
    std::vector<double> x(s.size(), 0.0);
    const bool motor = reads_motor_angle(term);
    std::vector<double> value(s.size(), 0.0);
    for (std::size_t k = 0; k < s.size(); ++k) {
        sim::TermInputs in = sample_inputs(s, k);
        if (motor && term.target == sim::TermTarget::Torque) {
            double sum = 0;
            for (int j = 0; j < kMotorAngleSubpoints; ++j) {
                const double f = (j + 0.5) / kMotorAngleSubpoints;
                in.theta_m = s.theta_start_rad[k] + f * (s.theta_m_rad[k] - s.theta_start_rad[k]);
                sum += sim::term_value(term, in);
            }
            value[k] = sum / kMotorAngleSubpoints;
        } else {
            value[k] = sim::term_value(term, in);
        }
    }
    switch (term.target) {
        case sim::TermTarget::Torque: x = value; break;
        case sim::TermTarget::Current:
            for (std::size_t k = 0; k < s.size(); ++k) x[k] = s.k_t_nm_per_a * value[k];
            break;
        case sim::TermTarget::Hinge:
            for (std::size_t k = 0; k < s.size(); ++k) x[k] = -value[k] / s.tau;
            break;
        case sim::TermTarget::Speed:
            for (std::size_t k = 1; k + 1 < s.size(); ++k) {
                x[k] = -s.j_kgm2 * (value[k + 1] - value[k - 1]) / (2.0 * s.sample_period_s);
            }
            break;
        case sim::TermTarget::Theta: break;
    }
    return x;
}

}  // namespace emadiag::discovery
