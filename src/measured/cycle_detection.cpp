#include "measured/cycle_detection.hpp"

#include "measured/differentiator.hpp"

#include <cmath>

namespace emadiag::measured {

std::vector<Cycle> detect_motion_cycles(const std::vector<double>& t_s, const std::vector<double>& x, const CycleSpec& spec) {
    std::vector<Cycle> cycles;
    const std::size_t n = t_s.size();
    if (n == 0) return cycles;
    std::vector<double> v(n, 0.0);
    differentiate(t_s, x, 0, n, Differentiator::central_difference, 1, 0.0, v);
    bool any_motion = false;
    int last_direction = 0;      // of the last moving row
    double last_moving_t_s = 0;  // its time
    std::vector<std::size_t> starts;
    for (std::size_t i = 0; i < n; ++i) {
        if (!(std::fabs(v[i]) > spec.speed_threshold_si)) continue;
        const int direction = v[i] > 0 ? 1 : -1;
        const bool wanted = spec.direction == MotionDirection::any || (spec.direction == MotionDirection::positive && direction > 0) ||
                            (spec.direction == MotionDirection::negative && direction < 0);
        const bool after_rest = !any_motion || (i > 0 && t_s[i] - last_moving_t_s >= spec.min_rest_s &&
                                                 !(std::fabs(v[i - 1]) > spec.speed_threshold_si));
        const bool reversal = any_motion && direction != last_direction;
        if (wanted && (after_rest || reversal)) starts.push_back(i);
        any_motion = true;
        last_direction = direction;
        last_moving_t_s = t_s[i];
    }
    for (std::size_t k = 0; k < starts.size(); ++k) {
        Cycle c;
        c.begin = starts[k];
        c.end = k + 1 < starts.size() ? starts[k + 1] : n;
        c.key = "motion " + std::to_string(k + 1);
        cycles.push_back(std::move(c));
    }
    return cycles;
}

}  // namespace emadiag::measured
