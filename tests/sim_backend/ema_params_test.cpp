// Parameter validation and eq. (4) (ema-reference.md sections 1 and 8).
#include "emadiag/sim/ema_params.hpp"
#include "emadiag/sim/sim_error.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace emadiag::sim {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

TEST(Eq4, EtaAFromEtaOMatchesDatasheet) {
    EXPECT_NEAR(eta_a_from_eta_o(0.85, 800.0), 0.823788, 5e-7);
}

TEST(Eq4, InverseRoundTripsOverTheDatasetRange) {
    for (double eta_a = 0.659031; eta_a <= 0.988546; eta_a += 0.01) {
        EXPECT_NEAR(eta_a_from_eta_o(eta_o_from_eta_a(eta_a, 800.0), 800.0), eta_a, 1e-12) << eta_a;
    }
}

TEST(EmaParams, DatasheetIsValid) {
    EXPECT_NO_THROW(EmaParams::datasheet().validate());
    EXPECT_NEAR(EmaParams::datasheet().eta_a, 0.823788, 5e-7);
}

struct BadField {
    const char* field;
    double value;
    const char* range;
};

class EmaParamsInvalid : public ::testing::TestWithParam<BadField> {};

TEST_P(EmaParamsInvalid, NamesFieldValueAndRange) {
    const auto& b = GetParam();
    nlohmann::json j;
    j[b.field] = b.value;
    if (std::string(b.field) == "fdj_nm") j["fsj_nm"] = 1e9;  // keep FSJ >= FDJ out of the way
    EXPECT_THAT([&] { (void)EmaParams::from_json(j); },
                ThrowsMessage<SimError>(AllOf(HasSubstr("[sim_backend]"), HasSubstr(b.field), HasSubstr(b.range))));
}

INSTANTIATE_TEST_SUITE_P(
    EveryField, EmaParamsInvalid,
    ::testing::Values(BadField{"v_dc_v", 0.0, "(0, inf)"}, BadField{"r_ohm", 0.0, "(0, inf)"},
                      BadField{"r_ohm", -1.0, "(0, inf)"}, BadField{"l_h", -2e-3, "(0, inf)"},
                      BadField{"k_t_nm_per_a", 0.0, "(0, inf)"}, BadField{"i_max_a", -20.0, "(0, inf)"},
                      BadField{"t_max_nm", 0.0, "(0, inf)"}, BadField{"w_max_rad_s", 0.0, "(0, inf)"},
                      BadField{"j_kgm2", 0.0, "(0, inf)"}, BadField{"tau", 0.5, "[1, inf)"},
                      BadField{"k_theta_per_s", 0.0, "(0, inf)"}, BadField{"k_w_a_s_per_rad", -0.25, "(0, inf)"},
                      BadField{"stop_deg", 95.0, "(0, 90]"}, BadField{"fdj_nm", -0.01, "[0, inf)"},
                      BadField{"fsj_nm", -0.1, "[0, inf)"}, BadField{"eta_o", 0.0, "(0, 1]"},
                      BadField{"eta_o", 1.2, "(0, 1]"}, BadField{"eta_a", 1.0, "(-inf, 1)"},
                      BadField{"dt_s", 0.0, "(0, 0.0001]"}),
    [](const auto& p) { return std::string(p.param.field) + "_" + std::to_string(p.index); });

TEST(EmaParams, ReportsEveryProblemNotJustTheFirst) {
    nlohmann::json j = {{"r_ohm", -1.0}, {"l_h", 0.0}};
    EXPECT_THAT([&] { (void)EmaParams::from_json(j); },
                ThrowsMessage<SimError>(AllOf(HasSubstr("r_ohm = -1"), HasSubstr("l_h = 0"))));
}

TEST(EmaParams, StaticBelowDynamicFrictionIsAnError) {
    nlohmann::json j = {{"fdj_nm", 0.1}, {"fsj_nm", 0.05}};
    EXPECT_THAT([&] { (void)EmaParams::from_json(j); },
                ThrowsMessage<SimError>(HasSubstr("fsj_nm = 0.05 must be >= fdj_nm = 0.1")));
}

TEST(EmaParams, UnknownKeysAndWrongTypesAreErrors) {
    EXPECT_THAT([&] { (void)EmaParams::from_json(nlohmann::json{{"resistance", 1.0}}, "p.json"); },
                ThrowsMessage<SimError>(HasSubstr("p.json.resistance: unknown parameter")));
    EXPECT_THAT([&] { (void)EmaParams::from_json(nlohmann::json{{"r_ohm", "one"}}, "p.json"); },
                ThrowsMessage<SimError>(HasSubstr("p.json.r_ohm: expected a number")));
    EXPECT_THAT([&] { (void)EmaParams::from_json(nlohmann::json{{"effects", {{"warp", 1.0}}}}, "p.json"); },
                ThrowsMessage<SimError>(HasSubstr("p.json.effects.warp: unknown effect")));
    EXPECT_THAT([&] { (void)EmaParams::from_json(nlohmann::json::array(), "p.json"); },
                ThrowsMessage<SimError>(HasSubstr("expected a JSON object")));
}

TEST(EmaParams, EffectRangesAreChecked) {
    Effects fx;
    EXPECT_THAT([&] { fx.set("viscous", -1.0); }, ThrowsMessage<SimError>(HasSubstr("effect viscous = -1")));
    EXPECT_THAT([&] { fx.set("no_such", 1.0); }, ThrowsMessage<SimError>(HasSubstr("unknown effect 'no_such'")));
    EmaParams p = EmaParams::datasheet();
    p.effects.current_gain_error = 0.9;
    EXPECT_THAT([&] { p.validate(); }, ThrowsMessage<SimError>(HasSubstr("effects.current_gain_error = 0.9")));
}

TEST(EmaParams, EtaAGivenAloneSetsEtaOByEq4) {
    const auto p = EmaParams::from_json(nlohmann::json{{"eta_a", 0.7}});
    EXPECT_NEAR(p.eta_o, eta_o_from_eta_a(0.7, 800.0), 1e-15);
}

TEST(EmaParams, JsonRoundTrip) {
    EmaParams p = EmaParams::datasheet();
    p.fdj_nm = 0.07;
    p.effects.viscous_nm_s_rad = 1e-5;
    const auto q = EmaParams::from_json(p.to_json());
    EXPECT_EQ(q.to_json(), p.to_json());
}

}  // namespace
}  // namespace emadiag::sim

namespace emadiag::sim {
namespace {

TEST(EmaParams, ShippedDatasheetFileEqualsTheBuiltInDatasheet) {
    const auto p = EmaParams::from_json_file(std::string(EMADIAG_SOURCE_DIR) + "/sim_backend/params/ema-ref-1.json");
    EXPECT_EQ(p.to_json(), EmaParams::datasheet().to_json());
}

TEST(EmaParams, ParameterFileErrorsNameTheFile) {
    EXPECT_THAT([] { (void)EmaParams::from_json_file("/nonexistent/p.json"); },
                ThrowsMessage<SimError>(HasSubstr("cannot open parameter file /nonexistent/p.json")));
}

}  // namespace
}  // namespace emadiag::sim
