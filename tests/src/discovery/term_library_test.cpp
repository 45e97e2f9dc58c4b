// Issue 22 part 2: which generated families are friction-like (sgn(w) times a shape) is a typed flag
// set where the family is built (TermFamily::opposes_motion), not a prefix read back from its name.
// The flag must pick exactly the families whose printed name is sgn(w) times something.
#include "discovery/screening/term_library.hpp"
#include "core/sim_run.hpp"
#include "discovery/model/run_signals.hpp"
#include "emadiag/sim/simulator.hpp"

#include <gtest/gtest.h>

#include <string_view>

namespace emadiag::discovery {
namespace {

TEST(TermLibrary, FrictionLikeFamiliesAreThoseThatMultiplySgnW) {
    sim::SimConfig c;
    c.sequence = sim::Sequence::Dyn;
    c.load_case = sim::LoadCase::B;
    c.noise = sim::NoiseProfile::None;
    c.duration_s = 0.5;
    const RunSignals s = run_signals(make_run(c, sim::simulate(c)));
    const std::vector<TermFamily> lib = generated_library(s);
    ASSERT_FALSE(lib.empty());
    int friction_like = 0;
    for (const auto& f : lib) {
        const bool printed_as_friction = std::string_view(f.name).starts_with("sgn(w)*");
        EXPECT_EQ(f.opposes_motion, printed_as_friction) << f.name;
        friction_like += f.opposes_motion ? 1 : 0;
    }
    EXPECT_GT(friction_like, 0);
    EXPECT_LT(friction_like, static_cast<int>(lib.size()));
}

}  // namespace
}  // namespace emadiag::discovery
