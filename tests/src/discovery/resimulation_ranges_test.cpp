// Issue 22 part 3: the ranges discovery fits an effect in are the simulator's (sim::Effects::range,
// the one definition), narrowed only where resimulation.cpp states why; they had drifted apart
// (stribeck_speed, spall_width, true_inertia) when discovery kept a copy of its own.
#include "discovery/model/resimulation.hpp"
#include "emadiag/sim/ema_params.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

namespace emadiag::discovery {
namespace {

TEST(ResimulationRanges, EveryFittedEffectIsASimulatorEffectAndItsFitRangeLiesInsideTheSimulators) {
    const auto& known = sim::Effects::names();
    const auto fitted = fitted_effect_names();
    ASSERT_FALSE(fitted.empty());
    for (std::size_t i = 0; i < fitted.size(); ++i) {
        const std::string& name = fitted[i];
        SCOPED_TRACE(name);
        ASSERT_NE(std::find(known.begin(), known.end(), name), known.end()) << name << " is not a simulator effect";
        const sim::Effects::Range sim_range = sim::Effects::range(name);
        const FitRange fit = fit_range(FitParameter::effect(static_cast<FittedEffect>(i)));
        EXPECT_GE(fit.lo, sim_range.min);
        EXPECT_LE(fit.hi, sim_range.max);
        EXPECT_LT(fit.lo, fit.hi);
        // A value at either end of the fit range is one the simulator accepts.
        sim::Effects e;
        EXPECT_NO_THROW(e.set(name, fit.lo));
        EXPECT_NO_THROW(e.set(name, fit.hi));
    }
}

TEST(ResimulationRanges, TheUpperEndsAreTheSimulatorsExactly) {
    const auto fitted = fitted_effect_names();
    for (std::size_t i = 0; i < fitted.size(); ++i) {
        EXPECT_EQ(fit_range(FitParameter::effect(static_cast<FittedEffect>(i))).hi, sim::Effects::range(fitted[i]).max) << fitted[i];
    }
}

TEST(ResimulationRanges, AnUnknownNameIsRefusedByTheSimulator) {
    EXPECT_ANY_THROW((void)sim::Effects::range("warp"));
}

}  // namespace
}  // namespace emadiag::discovery
