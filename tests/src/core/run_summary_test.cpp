// The reference figures of ema-reference.md section 7 for the nominal DYN run in case B, noise none.
#include "core/run_summary.hpp"
#include "core/sim_run.hpp"

#include <gtest/gtest.h>

namespace emadiag {
namespace {

TEST(RunSummary, ReproducesTheDatasheetReferenceFigures) {
    sim::SimConfig c;  // datasheet, case B, DYN, noise none
    const RunSummary s = summarise(make_run(c, sim::simulate(c)));
    ASSERT_TRUE(s.reversal_s.has_value());
    EXPECT_NEAR(s.reversal_s->first, 0.2320, 1e-9);
    EXPECT_NEAR(s.reversal_s->second, 0.2325, 1e-9);
    EXPECT_NEAR(s.min_surface_deg, -11.872, 5e-4);
    ASSERT_TRUE(s.tr_plateau_down_nm && s.tr_plateau_up_nm);
    EXPECT_NEAR(*s.tr_plateau_down_nm, -0.1802, 5e-5);
    EXPECT_NEAR(*s.tr_plateau_up_nm, 0.1413, 5e-5);
    EXPECT_GT(s.peak_current_a, 20.0);  // the chatter takes the mean a little above I_max (section 7)
    EXPECT_LT(s.peak_current_a, 20.2);
}

}  // namespace
}  // namespace emadiag
