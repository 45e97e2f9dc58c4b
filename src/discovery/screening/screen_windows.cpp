#include "discovery/screening/screen_windows.hpp"

#include "core/emadiag_error.hpp"

#include <cstdio>

namespace emadiag::discovery {

Eigen::VectorXd WindowedBase::window_sums(const std::vector<double>& full) const {
    const auto ni = static_cast<Eigen::Index>(windows.size());
    Eigen::VectorXd v(ni);
    for (Eigen::Index i = 0; i < ni; ++i) {
        double sum = 0;
        for (std::size_t k : windows[static_cast<std::size_t>(i)]) sum += full[k];
        v(i) = sum;
    }
    return v;
}

WindowedBase windowed_base(const RunSignals& s, const ScreenInput& in) {
    WindowedBase b;
    for (std::size_t k = 0; k < s.size() && k < in.mask.size(); ++k) {
        if (in.mask[k]) b.rows.push_back(k);
    }
    if (b.rows.size() < kMinScreenSamples) {
        throw EmadiagError("discovery: " + std::to_string(b.rows.size()) + " comparison samples (slipping in the run "
                           "and the model); at least " + std::to_string(kMinScreenSamples) + " are needed");
    }
    for (std::size_t k : b.rows) {
        if (b.windows.empty() || b.windows.back().size() == kScreenWindowSamples || k != b.windows.back().back() + 1) {
            b.windows.emplace_back();
        }
        b.windows.back().push_back(k);
    }
    for (const auto& w : b.windows) b.weight_sum += static_cast<double>(w.size() * w.size());
    const auto ni = static_cast<Eigen::Index>(b.windows.size());
    const auto p = static_cast<Eigen::Index>(in.base_columns.size());
    b.y = b.window_sums(in.residual_nm);
    b.x0.resize(ni, p);
    for (Eigen::Index j = 0; j < p; ++j) b.x0.col(j) = b.window_sums(in.base_columns[static_cast<std::size_t>(j)]);
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(b.x0);
    b.q = qr.householderQ() * Eigen::MatrixXd::Identity(ni, p);
    b.e0 = b.y - b.q * (b.q.transpose() * b.y);
    b.rss0 = b.e0.squaredNorm();
    return b;
}

std::string fmt3(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.3g", v);
    return b;
}

std::string fmt4(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.4g", v);
    return b;
}

}  // namespace emadiag::discovery
