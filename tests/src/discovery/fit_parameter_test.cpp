// Issue 22 part 2: fit parameters are addressed by a typed id; fit_parameter_name is the one printer
// (the names reports and JSON show); nothing parses a name back, the id carries its kind and index.
#include "discovery/model/fit_parameter.hpp"
#include "discovery/model/resimulation.hpp"
#include "core/emadiag_error.hpp"
#include "emadiag/sim/ema_params.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

namespace emadiag::discovery {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

TEST(FitParameter, PrintsTheNamesReportsShow) {
    EXPECT_EQ(fit_parameter_name(FitParameter::fdj()), "fdj_nm");
    EXPECT_EQ(fit_parameter_name(FitParameter::eta_o()), "eta_o");
    EXPECT_EQ(fit_parameter_name(FitParameter::effect(FittedEffect::StribeckAmplitude)), "stribeck_amplitude");
    EXPECT_EQ(fit_parameter_name(FitParameter::term(0)), "term:0");
    EXPECT_EQ(fit_parameter_name(FitParameter::term(12)), "term:12");
}

TEST(FitParameter, EveryIdKeepsItsKindAndIndexAndPrintsItsOwnName) {
    EXPECT_EQ(FitParameter::fdj().kind(), FitParameter::Kind::Fdj);
    EXPECT_EQ(FitParameter::eta_o().kind(), FitParameter::Kind::EtaO);
    EXPECT_TRUE(FitParameter::fdj().is_health());
    EXPECT_TRUE(FitParameter::eta_o().is_health());
    std::vector<FitParameter> all = {FitParameter::fdj(), FitParameter::eta_o()};
    for (const std::size_t k : {0U, 1U, 31U}) {
        const FitParameter t = FitParameter::term(k);
        EXPECT_EQ(t.kind(), FitParameter::Kind::Term);
        EXPECT_EQ(t.term_index(), k);
        EXPECT_FALSE(t.is_health());
        all.push_back(t);
    }
    for (std::size_t i = 0; i < kFittedEffectCount; ++i) {
        const auto e = static_cast<FittedEffect>(i);
        const FitParameter p = FitParameter::effect(e);
        EXPECT_EQ(p.kind(), FitParameter::Kind::Effect);
        EXPECT_EQ(p.fitted_effect(), e);
        EXPECT_EQ(fit_parameter_name(p), effect_name(e));
        EXPECT_FALSE(p.is_health());
        all.push_back(p);
    }
    // Ids are equal exactly when they name the same parameter, and each prints a name of its own.
    for (std::size_t a = 0; a < all.size(); ++a) {
        for (std::size_t b = 0; b < all.size(); ++b) {
            SCOPED_TRACE(fit_parameter_name(all[a]) + " / " + fit_parameter_name(all[b]));
            EXPECT_EQ(all[a] == all[b], a == b);
            EXPECT_EQ(fit_parameter_name(all[a]) == fit_parameter_name(all[b]), a == b);
        }
    }
}

TEST(FitParameter, TheFittedEffectsAreTheOnesResimulationFits) {
    const std::vector<std::string> names = fitted_effect_names();
    ASSERT_EQ(names.size(), kFittedEffectCount);
    for (std::size_t i = 0; i < kFittedEffectCount; ++i) {
        EXPECT_EQ(names[i], effect_name(static_cast<FittedEffect>(i)));
    }
    // a simulator effect that discovery does not fit
    EXPECT_EQ(std::find(names.begin(), names.end(), "backlash"), names.end());
}

TEST(FitParameter, GetAndSetById) {
    sim::EmaParams p = sim::EmaParams::datasheet();
    p.terms.push_back(sim::parse_term("torque: 0.01*sgn(w)"));
    set_parameter(p, FitParameter::term(0), 0.25);
    EXPECT_EQ(get_parameter(p, FitParameter::term(0)), 0.25);
    set_parameter(p, FitParameter::effect(FittedEffect::StribeckAmplitude), 0.03);
    EXPECT_EQ(get_parameter(p, FitParameter::effect(FittedEffect::StribeckAmplitude)), 0.03);
    set_parameter(p, FitParameter::eta_o(), 0.8);
    EXPECT_EQ(p.eta_a, sim::eta_a_from_eta_o(0.8, p.tau));
    EXPECT_THAT([&] { (void)get_parameter(p, FitParameter::term(1)); },
                ThrowsMessage<EmadiagError>(HasSubstr("parameter 'term:1': the model has 1 terms")));
}

}  // namespace
}  // namespace emadiag::discovery
