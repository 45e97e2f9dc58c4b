#include "measured/differentiator.hpp"

#include <cmath>

namespace emadiag::measured {

namespace {

double sum_k_squared(int m) { return static_cast<double>(m) * (m + 1) * (2 * m + 1) / 3.0; }

double central(const std::vector<double>& t_s, const std::vector<double>& x, std::size_t i, std::size_t begin, std::size_t end) {
    const std::size_t lo = i > begin ? i - 1 : i;
    const std::size_t hi = i + 1 < end ? i + 1 : i;
    return (x[hi] - x[lo]) / (t_s[hi] - t_s[lo]);
}

}  // namespace

void differentiate(const std::vector<double>& t_s, const std::vector<double>& x, std::size_t begin, std::size_t end,
                   Differentiator method, int half_window, double nominal_period_s, std::vector<double>& out) {
    if (end <= begin) return;
    if (end - begin == 1) {
        out[begin] = 0.0;
        return;
    }
    const std::size_t m = method == Differentiator::savitzky_golay ? static_cast<std::size_t>(half_window) : 1;
    const double denom = nominal_period_s * sum_k_squared(static_cast<int>(m));
    for (std::size_t i = begin; i < end; ++i) {
        if (method == Differentiator::central_difference || m == 1 || i < begin + m || i + m >= end) {
            out[i] = central(t_s, x, i, begin, end);
            continue;
        }
        double acc = 0.0;
        for (std::size_t k = 1; k <= m; ++k) acc += static_cast<double>(k) * (x[i + k] - x[i - k]);
        out[i] = acc / denom;
    }
}

double derivative_noise_gain_per_s(Differentiator method, int half_window, double nominal_period_s) {
    const int m = method == Differentiator::savitzky_golay ? half_window : 1;
    return 1.0 / (nominal_period_s * std::sqrt(sum_k_squared(m)));
}

}  // namespace emadiag::measured
