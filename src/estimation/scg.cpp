#include "estimation/eigen_dense.hpp"  // first: Eigen with its AVX-512 false positive scoped (see there)
#include "estimation/scg.hpp"

#include "core/emadiag_error.hpp"

#include <cmath>
#include <limits>

namespace emadiag {

ScgResult train_scg(const ScgObjective& objective, Eigen::VectorXd x0, const ScgOptions& options,
                    const ScgValidation& validation) {
    if (options.sigma <= 0 || options.lambda <= 0) {
        throw EmadiagError("SCG sigma " + std::to_string(options.sigma) + " and lambda " +
                           std::to_string(options.lambda) + " must be positive");
    }
    if (x0.size() == 0) throw EmadiagError("SCG needs at least one weight");
    // MATLAB keeps gX as the NEGATIVE gradient (the steepest-descent direction); so do we.
    Eigen::VectorXd x = std::move(x0);
    Eigen::VectorXd grad;
    double perf = objective(x, &grad);
    Eigen::VectorXd g = -grad;
    Eigen::VectorXd g_old = g;
    Eigen::VectorXd d = g;  // initial search direction
    double nrmsqr_d = d.squaredNorm();
    double norm_d = std::sqrt(nrmsqr_d);
    bool success = true;
    double lambda_b = 0;
    double lambda_k = options.lambda;
    double delta_k = 0;
    const long num_x = x.size();

    ScgResult r;
    r.x = x;
    r.perf = perf;
    double best_vperf = std::numeric_limits<double>::infinity();
    int val_fail = 0;
    Eigen::VectorXd x_temp, g_temp;

    for (int epoch = 0;; ++epoch) {
        // Validation and bookkeeping (trainscg checks these at the start of each epoch).
        r.perf_history.push_back(perf);
        if (validation) {
            const double vperf = validation(x);
            r.validation_history.push_back(vperf);
            if (vperf < best_vperf) {
                best_vperf = vperf;
                r.x = x;
                r.perf = perf;
                r.validation_perf = vperf;
                r.best_epoch = epoch;
                val_fail = 0;
            } else if (vperf > best_vperf) {
                ++val_fail;
            }
        } else {
            r.x = x;
            r.perf = perf;
            r.best_epoch = epoch;
        }
        r.epochs = epoch;
        if (perf <= options.goal) {
            r.stop_reason = "goal";
            break;
        }
        if (g.norm() < options.min_grad) {
            r.stop_reason = "min_grad";
            break;
        }
        if (epoch == options.max_epochs) {
            r.stop_reason = "max_epochs";
            break;
        }
        if (validation && val_fail >= options.max_fail) {
            r.stop_reason = "validation";
            break;
        }
        if (!(norm_d > 0) || !std::isfinite(norm_d)) {
            r.stop_reason = "no_step";
            break;
        }

        // Second-order information along d (finite difference of gradients).
        if (success) {
            const double sigma_k = options.sigma / norm_d;
            x_temp = x + sigma_k * d;
            (void)objective(x_temp, &g_temp);
            const Eigen::VectorXd s_k = (g + g_temp) / sigma_k;  // (gX - gX_temp) / sigma_k with gX = -grad
            delta_k = d.dot(s_k);
        }
        // Scale delta_k.
        delta_k += (lambda_k - lambda_b) * nrmsqr_d;
        // Make the Hessian positive definite if needed.
        if (delta_k <= 0) {
            lambda_b = 2.0 * (lambda_k - delta_k / nrmsqr_d);
            delta_k = -delta_k + lambda_k * nrmsqr_d;
            lambda_k = lambda_b;
        }
        // Step size.
        const double mu_k = d.dot(g);
        const double alpha_k = mu_k / delta_k;
        // Comparison parameter.
        x_temp = x + alpha_k * d;
        const double perf_temp = objective(x_temp, nullptr);
        const double dif_k = 2.0 * delta_k * (perf - perf_temp) / (mu_k * mu_k);

        if (dif_k >= 0) {  // a successful reduction in error
            g_old = g;
            x = x_temp;
            perf = objective(x, &grad);
            g = -grad;
            lambda_b = 0;
            success = true;
            // Restart every num_x iterations.
            if (epoch % num_x == 0) {  // MATLAB: rem(epoch, num_X) == 0, epoch from 0
                d = g;
            } else {
                const double beta_k = (g.squaredNorm() - g.dot(g_old)) / mu_k;
                d = g + beta_k * d;
            }
            nrmsqr_d = d.squaredNorm();
            norm_d = std::sqrt(nrmsqr_d);
            if (dif_k >= 0.75) lambda_k = 0.25 * lambda_k;
        } else {
            lambda_b = lambda_k;
            success = false;
        }
        if (dif_k < 0.25) lambda_k = lambda_k + delta_k * (1.0 - dif_k) / nrmsqr_d;
    }
    return r;
}

}  // namespace emadiag
