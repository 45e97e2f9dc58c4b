#pragma once
// Time derivatives of a sampled signal (docs/column-map.md, "Derived signals"), over one segment
// [begin, end) of rows at a time (a cycle, or the whole run), never across a segment's edge.
//  - central difference: v_i = (x_{i+1} - x_{i-1}) / (t_{i+1} - t_{i-1}); one-sided at the two ends.
//    White position noise sigma becomes sigma_v = sigma / (sqrt(2) h) inside, sqrt(2) sigma / h at an end.
//  - Savitzky-Golay (quadratic, window 2m+1, nominal period h): v_i = sum_k k x_{i+k} / (h S),
//    S = sum_{k=-m..m} k^2 = m (m+1) (2m+1) / 3; sigma_v = sigma / (h sqrt(S)). Within m rows of an
//    end it falls back to the central difference. m = 1 is the central difference.
#include "measured/column_map.hpp"

#include <cstddef>
#include <vector>

namespace emadiag::measured {

/// Writes d x / d t of rows [begin, end) into out[begin, end). A segment of one row gets 0.
void differentiate(const std::vector<double>& t_s, const std::vector<double>& x, std::size_t begin, std::size_t end,
                   Differentiator method, int half_window, double nominal_period_s, std::vector<double>& out);

/// sigma_v / sigma_x inside a segment (1/s): 1 / (h sqrt(S)), S as above (S = 2 for the central difference).
[[nodiscard]] double derivative_noise_gain_per_s(Differentiator method, int half_window, double nominal_period_s);

}  // namespace emadiag::measured
