#pragma once
// Synthetic measurement series with a known truth, for the property tests and the RUL benchmark:
// y(t) = truth(t) + se * z, z ~ N(0, 1) (NormalSampler), sessions every days_between days.
#include "prognostics/normal_sampler.hpp"
#include "prognostics/trend_series.hpp"

#include <functional>
#include <vector>

namespace emadiag::prognostics {

struct SyntheticHistory {
    int sessions = 8;
    double days_between = 30.0;
    double std_error = 0.0005;  ///< the se every point claims, and the sigma of its noise
};

/// Points at t = 0, days_between, ... with value truth(t) plus noise (none when `noise` is null);
/// session ids 1, 2, ...
[[nodiscard]] std::vector<TrendPoint> synthetic_points(const SyntheticHistory& h, const std::function<double(double)>& truth,
                                                       NormalSampler* noise);

}  // namespace emadiag::prognostics
