#include "prognostics/prognostics_metrics.hpp"

#include "core/emadiag_error.hpp"

#include <cmath>
#include <sstream>
#include <string>

namespace emadiag::prognostics {
namespace {

std::string str(double v) {
    std::ostringstream os;
    os << v;
    return os.str();
}

void check_alpha_beta(double alpha, double beta) {
    if (!(alpha > 0 && alpha < 1)) throw EmadiagError("prognostic metric: alpha " + str(alpha) + " must be within (0, 1)");
    if (!(beta > 0 && beta <= 1)) throw EmadiagError("prognostic metric: beta " + str(beta) + " must be within (0, 1]");
}

void check_profile(const std::vector<RulPrediction>& profile, double true_eol) {
    if (!std::isfinite(true_eol)) throw EmadiagError("prognostic metric: true end of life " + str(true_eol) + " is not finite");
    for (std::size_t i = 0; i < profile.size(); ++i) {
        const double t = profile[i].t;
        const std::string at = "prognostic metric: prediction " + std::to_string(i);
        if (!std::isfinite(t)) throw EmadiagError(at + " time " + str(t) + " is not finite");
        if (i > 0 && !(t > profile[i - 1].t))
            throw EmadiagError(at + " time " + str(t) + " is not after prediction " + std::to_string(i - 1) + "'s " + str(profile[i - 1].t));
        if (!(t < true_eol)) throw EmadiagError(at + " time " + str(t) + " is not before the true end of life " + str(true_eol));
        if (profile[i].rul_point && !std::isfinite(*profile[i].rul_point))
            throw EmadiagError(at + " point RUL " + str(*profile[i].rul_point) + " is not finite");
    }
}

}  // namespace

double fraction_within_alpha(const std::vector<double>& rul_samples, double true_rul, double alpha) {
    check_alpha_beta(alpha, 1.0);
    if (!(true_rul > 0) || !std::isfinite(true_rul)) throw EmadiagError("prognostic metric: true RUL " + str(true_rul) + " must be positive");
    if (rul_samples.empty()) throw EmadiagError("prognostic metric: a prediction has no RUL samples");
    const double lo = (1 - alpha) * true_rul, hi = (1 + alpha) * true_rul;
    std::size_t within = 0;
    for (std::size_t i = 0; i < rul_samples.size(); ++i) {
        const double r = rul_samples[i];
        if (std::isnan(r)) throw EmadiagError("prognostic metric: RUL sample " + std::to_string(i) + " is NaN");
        if (r >= lo && r <= hi) ++within;
    }
    return static_cast<double>(within) / static_cast<double>(rul_samples.size());
}

AlphaLambdaResult alpha_lambda(const std::vector<RulPrediction>& profile, double true_eol, double lambda, double alpha, double beta) {
    check_alpha_beta(alpha, beta);
    if (!(lambda >= 0 && lambda <= 1)) throw EmadiagError("prognostic metric: lambda " + str(lambda) + " must be within [0, 1]");
    check_profile(profile, true_eol);
    AlphaLambdaResult r;
    if (profile.empty()) return r;
    const double t_p = profile.front().t;
    r.t_lambda = t_p + lambda * (true_eol - t_p);
    for (const auto& p : profile) {
        if (p.t < r.t_lambda) continue;
        r.evaluated = true;
        r.t_evaluated = p.t;
        r.true_rul = true_eol - p.t;
        r.fraction_within = fraction_within_alpha(p.rul_samples, r.true_rul, alpha);
        r.met = r.fraction_within >= beta;
        break;
    }
    return r;
}

double relative_accuracy(double predicted_rul, double true_rul) {
    if (!std::isfinite(predicted_rul) || !std::isfinite(true_rul) || !(true_rul > 0)) {
        throw EmadiagError("relative accuracy: predicted RUL " + str(predicted_rul) + " must be finite and true RUL " + str(true_rul) +
                           " finite and positive");
    }
    return 1.0 - std::abs(true_rul - predicted_rul) / true_rul;
}

std::optional<double> prognostic_horizon(const std::vector<RulPrediction>& profile, double true_eol, double alpha, double beta) {
    check_alpha_beta(alpha, beta);
    check_profile(profile, true_eol);
    for (const auto& p : profile) {
        if (fraction_within_alpha(p.rul_samples, true_eol - p.t, alpha) >= beta) return true_eol - p.t;
    }
    return std::nullopt;
}

}  // namespace emadiag::prognostics
