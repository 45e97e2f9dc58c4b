#include "measured/derived_signals.hpp"

#include "measured/differentiator.hpp"
#include "measured/measured_error.hpp"
#include "measured/number_text.hpp"

#include <cmath>

namespace emadiag::measured {

MeasuredSignal derive_signal(const MeasuredRun& run, const DerivedSpec& d, const std::string& map_path) {
    const MeasuredSignal* a = run.signal(d.of[0]);
    const MeasuredSignal* b = d.of.size() > 1 ? run.signal(d.of[1]) : nullptr;
    MeasuredSignal out;
    out.name = d.signal;
    const std::size_t n = run.time_s.size();
    out.values.resize(n);
    if (d.op == DerivedOp::derivative) {
        const auto q = derivative_quantity(a->quantity);
        if (!q) {
            throw MeasuredError("column map " + map_path + ": derived '" + d.signal + "': the derivative of a " + std::string(quantity_name(a->quantity)) +
                                " ('" + a->name + "') is not supported (length, linear_speed, angle and angular_speed are)");
        }
        out.quantity = *q;
        const double h = run.nominal_period_s;
        if (d.per_cycle && !run.cycles.empty()) {
            std::size_t at = 0;
            for (const Cycle& c : run.cycles) {
                differentiate(run.time_s, a->values, at, c.begin, d.method, d.half_window, h, out.values);  // rows before the cycle
                differentiate(run.time_s, a->values, c.begin, c.end, d.method, d.half_window, h, out.values);
                at = c.end;
            }
            differentiate(run.time_s, a->values, at, n, d.method, d.half_window, h, out.values);
        } else {
            differentiate(run.time_s, a->values, 0, n, d.method, d.half_window, h, out.values);
        }
        out.noise_gain_per_s = derivative_noise_gain_per_s(d.method, d.half_window, h);
        out.noise_si = a->noise_si * out.noise_gain_per_s;
        out.origin = "derivative of " + a->name + " by " + (d.method == Differentiator::central_difference ? "central difference" :
                     "Savitzky-Golay (quadratic, window " + std::to_string(2 * d.half_window + 1) + ")") + ", h = " + number_text(h) + " s" +
                     (d.per_cycle ? ", per cycle" : "");
    } else {
        if (a->quantity != b->quantity) {
            throw MeasuredError("column map " + map_path + ": derived '" + d.signal + "': '" + a->name + "' is a " + std::string(quantity_name(a->quantity)) +
                                " and '" + b->name + "' a " + std::string(quantity_name(b->quantity)) + ": a " +
                                (d.op == DerivedOp::sum ? "sum" : "difference") + " needs one quantity");
        }
        out.quantity = a->quantity;
        const double sgn = d.op == DerivedOp::sum ? 1.0 : -1.0;
        for (std::size_t i = 0; i < n; ++i) out.values[i] = a->values[i] + sgn * b->values[i];
        out.noise_si = std::hypot(a->noise_si, b->noise_si);
        out.origin = a->name + (d.op == DerivedOp::sum ? " + " : " - ") + b->name;
    }
    return out;
}


}  // namespace emadiag::measured
