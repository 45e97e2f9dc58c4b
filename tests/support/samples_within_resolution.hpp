#pragma once
// Test support: a run received over CAN against the direct simulation it stands for. Every
// column must agree to within half its CAN signal resolution (time and command exactly).
#include "core/run.hpp"
#include "emadiag/sim/simulator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <ostream>

namespace emadiag::test {

/// Checks every sample; when `report` is given, also prints the largest difference per channel.
inline ::testing::AssertionResult samples_within_resolution(const Run& got, const sim::SimResult& want,
                                                           std::ostream* report = nullptr) {
    if (got.samples.size() != want.samples.size())
        return ::testing::AssertionFailure() << got.samples.size() << " samples, direct simulation has " << want.samples.size();
    constexpr double kSlack = 1e-9;
    const double lim[] = {1e-12, sim::kCurrentResolutionA / 2, sim::kSpeedResolutionRadS / 2, sim::kThetaResolutionRad / 2,
                          sim::kHingeResolutionNm / 2, 1e-9};
    double worst[6] = {0, 0, 0, 0, 0, 0};
    for (std::size_t k = 0; k < got.samples.size(); ++k) {
        const auto& g = got.samples[k];
        const auto& w = want.samples[k];
        const double d[] = {std::abs(g.t_s - w.t_s), std::abs(g.current_a - w.current_a), std::abs(g.speed_rad_s - w.speed_rad_s),
                            std::abs(g.theta_m_rad - w.theta_m_rad), std::abs(g.hinge_moment_nm - w.hinge_moment_nm),
                            std::abs(g.command_deg - w.command_deg)};
        for (int i = 0; i < 6; ++i) {
            worst[i] = std::max(worst[i], d[i]);
            if (d[i] > lim[i] + kSlack)
                return ::testing::AssertionFailure() << "sample " << k << " column " << i << " differs by " << d[i] << " > " << lim[i];
        }
    }
    if (report) {
        *report << "  largest differences: current " << worst[1] << " A, speed " << worst[2] << " rad/s, theta " << worst[3]
                << " rad, hinge " << worst[4] << " N m\n";
    }
    return ::testing::AssertionSuccess();
}

}  // namespace emadiag::test
