#include "prognostics/synthetic_history.hpp"

namespace emadiag::prognostics {

std::vector<TrendPoint> synthetic_points(const SyntheticHistory& h, const std::function<double(double)>& truth, NormalSampler* noise) {
    std::vector<TrendPoint> points;
    for (int i = 0; i < h.sessions; ++i) {
        TrendPoint p;
        p.session_id = i + 1;
        p.t_days = i * h.days_between;
        p.value = truth(p.t_days) + (noise ? h.std_error * noise->next() : 0.0);
        p.std_error = h.std_error;
        p.estimators = {"synthetic"};
        points.push_back(std::move(p));
    }
    return points;
}

}  // namespace emadiag::prognostics
