// The simulator's sensor resolutions (sim_backend simulator.hpp) are the ICD's signal factors
// (can_dbc/ema.dbc), so simulated and CAN-recorded runs are quantised alike.
#include "emadiag/can/ema_icd.hpp"
#include "emadiag/sim/simulator.hpp"

#include <gtest/gtest.h>

TEST(IcdResolution, SimulatorSensorResolutionsEqualTheDbcFactors) {
    const emadiag::can::EmaIcd icd;
    EXPECT_EQ(icd.current_resolution_a(), emadiag::sim::kCurrentResolutionA);
    EXPECT_EQ(icd.speed_resolution_rad_s(), emadiag::sim::kSpeedResolutionRadS);
    EXPECT_EQ(icd.theta_resolution_rad(), emadiag::sim::kThetaResolutionRad);
    EXPECT_EQ(icd.hinge_resolution_nm(), emadiag::sim::kHingeResolutionNm);
    EXPECT_EQ(icd.ident.find_signal("SamplePeriod")->factor, 1e-6);
}
