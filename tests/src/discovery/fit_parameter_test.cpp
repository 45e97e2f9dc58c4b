// Issue 22 part 2: fit parameters are addressed by a typed id; fit_parameter_name is the one printer
// (the names reports and JSON show), and the string bridge kept for discovery.cpp reads them back.
#include "discovery/model/fit_parameter.hpp"
#include "discovery/model/resimulation.hpp"
#include "core/emadiag_error.hpp"
#include "emadiag/sim/ema_params.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

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
    EXPECT_EQ(term_parameter(7), "term:7");
}

TEST(FitParameter, EveryPrintedNameReadsBackAsTheSameParameter) {
    std::vector<FitParameter> all = {FitParameter::fdj(), FitParameter::eta_o(), FitParameter::term(0), FitParameter::term(31)};
    for (std::size_t i = 0; i < kFittedEffectCount; ++i) all.push_back(FitParameter::effect(static_cast<FittedEffect>(i)));
    for (const auto& p : all) {
        const std::string name = fit_parameter_name(p);
        SCOPED_TRACE(name);
        EXPECT_EQ(fit_parameter_from_name(name), p);
        EXPECT_EQ(is_term_parameter(name), p.kind() == FitParameter::Kind::Term);
    }
    EXPECT_NE(FitParameter::term(1), FitParameter::term(2));
    EXPECT_NE(FitParameter::fdj(), FitParameter::eta_o());
}

TEST(FitParameter, TheFittedEffectsAreTheOnesResimulationFits) {
    const std::vector<std::string> names = fitted_effect_names();
    ASSERT_EQ(names.size(), kFittedEffectCount);
    for (std::size_t i = 0; i < kFittedEffectCount; ++i) {
        EXPECT_EQ(names[i], effect_name(static_cast<FittedEffect>(i)));
        EXPECT_EQ(fitted_effect(names[i]), static_cast<FittedEffect>(i));
    }
    EXPECT_EQ(fitted_effect("backlash"), std::nullopt);  // a simulator effect that discovery does not fit
}

TEST(FitParameter, ANameNoFitTakesIsRefusedByName) {
    for (const char* bad : {"warp", "term:", "term:x", "term:-1", "Term:1", "backlash", "FDJ_Nm"}) {
        SCOPED_TRACE(bad);
        EXPECT_EQ(find_fit_parameter(bad), std::nullopt);
        EXPECT_FALSE(is_term_parameter(bad));
        EXPECT_THAT([&] { (void)fit_parameter_from_name(bad); },
                    ThrowsMessage<EmadiagError>(HasSubstr("parameter '" + std::string(bad) + "' cannot be fitted")));
    }
}

TEST(FitParameter, GetAndSetByIdAndByNameAgree) {
    sim::EmaParams p = sim::EmaParams::datasheet();
    p.terms.push_back(sim::parse_term("torque: 0.01*sgn(w)"));
    set_parameter(p, FitParameter::term(0), 0.25);
    EXPECT_EQ(get_parameter(p, "term:0"), 0.25);
    set_parameter(p, "stribeck_amplitude", 0.03);
    EXPECT_EQ(get_parameter(p, FitParameter::effect(FittedEffect::StribeckAmplitude)), 0.03);
    set_parameter(p, FitParameter::eta_o(), 0.8);
    EXPECT_EQ(p.eta_a, sim::eta_a_from_eta_o(0.8, p.tau));
    EXPECT_THAT([&] { (void)get_parameter(p, FitParameter::term(1)); },
                ThrowsMessage<EmadiagError>(HasSubstr("parameter 'term:1': the model has 1 terms")));
}

}  // namespace
}  // namespace emadiag::discovery
