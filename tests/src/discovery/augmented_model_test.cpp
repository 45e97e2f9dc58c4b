// The augmented model is data: its JSON goes back into sim::EmaParams (apply_model), and
// re-simulating with it reproduces the error the discovery reported.
#include "core/emadiag_error.hpp"
#include "core/sim_run.hpp"
#include "discovery/model/augmented_model.hpp"
#include "discovery/screening/candidate_effect.hpp"
#include "discovery/discovery.hpp"
#include "discovery/model/resimulation.hpp"
#include "discovery/model/run_signals.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

namespace {

using emadiag::EmadiagError;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

emadiag::Run spall_run() {
    emadiag::sim::SimConfig c;
    c.params.effects.set("spall_amplitude", 0.06);
    c.params.effects.set("spall_center", -5.0);
    c.params.effects.set("spall_width", 1.0);
    c.noise = emadiag::sim::NoiseProfile::Typical;
    c.seed = 3;
    return emadiag::make_run(c, emadiag::sim::simulate(c));
}

TEST(AugmentedModel, JsonReadsBackAndReSimulatesToTheReportedError) {
    constexpr double kSameErrorRel = 1e-9;
    const emadiag::Run run = spall_run();
    const auto report = emadiag::discovery::discover(run);
    const nlohmann::json j = nlohmann::json::parse(report.model.to_json().dump());
    EXPECT_EQ(j["version"], 1);
    EXPECT_EQ(j["base"], "EMA-REF-1 datasheet");
    ASSERT_FALSE(j["terms"].empty());
    EXPECT_EQ(j["terms"][0]["effect"], "spall_amplitude_nm");
    EXPECT_TRUE(j["health"].contains("FDJ_Nm"));
    EXPECT_TRUE(j["error_before"].contains("current_rms_A"));

    emadiag::sim::EmaParams p = emadiag::sim::EmaParams::datasheet();
    emadiag::discovery::apply_model(j, p);
    EXPECT_DOUBLE_EQ(p.effects.spall_amplitude_nm, report.model.params.effects.spall_amplitude_nm);
    EXPECT_DOUBLE_EQ(p.fdj_nm, report.model.params.fdj_nm);

    // Re-simulate with the model read back: the same error as reported after.
    const auto measured = emadiag::discovery::run_signals(run);
    const auto base = emadiag::discovery::run_signals(emadiag::discovery::resimulate(run, emadiag::sim::EmaParams::datasheet()));
    const auto model = emadiag::discovery::run_signals(emadiag::discovery::resimulate(run, p));
    // The comparison samples of the report are those of the baseline; the current metric uses all.
    const auto e = emadiag::discovery::model_error(measured, model, emadiag::discovery::comparison_mask(measured, base));
    EXPECT_NEAR(e.current_rms_a, report.model.error_after.current_rms_a, kSameErrorRel * report.model.error_after.current_rms_a);

    // The sim_params block is what `emadiag simulate --params` reads.
    const auto q = emadiag::sim::EmaParams::from_json(j["sim_params"]);
    EXPECT_DOUBLE_EQ(q.effects.spall_center_deg, p.effects.spall_center_deg);
}

TEST(AugmentedModel, ApplyModelListsEveryProblem) {
    const nlohmann::json bad = {{"version", 2},
                                {"health", {{"FDJ_Nm", {{"value", "x"}}}}},
                                {"terms", {{{"effect", "warp_drive"}, {"value", 1.0}}, {{"effect", "viscous_nm_s_rad"}}}}};
    emadiag::sim::EmaParams p = emadiag::sim::EmaParams::datasheet();
    EXPECT_THAT([&] { emadiag::discovery::apply_model(bad, p); },
                ThrowsMessage<EmadiagError>(AllOf(HasSubstr("model.version: expected 1, got 2"),
                                                  HasSubstr("model.health.FDJ_Nm.value: expected a number"),
                                                  HasSubstr("model.terms[0]: [emadiag] unknown effect field 'warp_drive'"),
                                                  HasSubstr("model.terms[1].value: expected a number"))));
    const nlohmann::json out_of_range = {{"version", 1}, {"terms", {{{"effect", "viscous_nm_s_rad"}, {"value", 2.0}}}}};
    EXPECT_THAT([&] { emadiag::discovery::apply_model(out_of_range, p); },
                ThrowsMessage<EmadiagError>(HasSubstr("effect viscous = 2 is outside the allowed range [0, 1]")));
}

TEST(AugmentedModel, EveryEffectNameHasAField) {
    for (const auto& name : emadiag::sim::Effects::names()) {
        const std::string field = emadiag::discovery::effect_field(name);
        EXPECT_EQ(emadiag::discovery::effect_sim_name(field), name);
    }
    EXPECT_THAT([] { (void)emadiag::discovery::effect_sim_name("nope"); },
                ThrowsMessage<EmadiagError>(HasSubstr("unknown effect field 'nope'; known: viscous_nm_s_rad")));
}

}  // namespace
