// An augmented model is usable by the estimators (`estimate --model AUGMENTED.json`): removing its
// terms from a run that has the effect reduces the physics estimator's residual and moves FDJ back
// to the truth; sensor terms are inverted exactly; what cannot be removed is a clear error.
#include "core/emadiag_error.hpp"
#include "core/sim_run.hpp"
#include "discovery/model/augmented_model.hpp"
#include "discovery/model/model_correction.hpp"
#include "estimation/health_estimate.hpp"
#include "estimation/physics_estimator.hpp"
#include "estimation/run_checks.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>

namespace {

using emadiag::EmadiagError;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;
namespace sim = emadiag::sim;
namespace dc = emadiag::discovery;

constexpr double kTrueFdjNm = 0.08;  // the datasheet's, which the simulated runs carry

/// Noise-free runs: the residual scale of typical noise is the derivative noise of eq. 7, which
/// hides how well the law fits (with noise, FDJ is checked instead).
emadiag::Run run_with(const sim::EmaParams& p, sim::NoiseProfile noise = sim::NoiseProfile::None) {
    sim::SimConfig c;
    c.params = p;
    c.noise = noise;
    c.seed = 5;
    return emadiag::make_run(c, sim::simulate(c));
}

double diagnostic(const emadiag::HealthEstimate& h, const std::string& name) {
    for (const auto& [k, v] : h.diagnostics) {
        if (k == name) return v;
    }
    ADD_FAILURE() << "no diagnostic " << name;
    return 0;
}

double fdj(const emadiag::HealthEstimate& h) {
    const auto* p = h.find(emadiag::kParamFdj);
    return p != nullptr && p->value ? *p->value : NAN;
}

/// The model JSON as `emadiag discover` writes it (only the fields apply_model reads).
sim::EmaParams read_model(const nlohmann::json& j) {
    EXPECT_TRUE(dc::is_discovery_model(j));
    sim::EmaParams p = sim::EmaParams::datasheet();
    dc::apply_model(j, p);
    return p;
}

TEST(ModelCorrection, ATermAsDataReducesTheResidualOfARunWithTheEffect) {
    sim::EmaParams truth = sim::EmaParams::datasheet();
    truth.terms = {sim::parse_term("torque: 0.01*sgn(w)*abs(theta_u)")};  // friction growing with deflection
    const emadiag::Run run = run_with(truth);
    const nlohmann::json model = {
        {"version", 1}, {"base", "EMA-REF-1 datasheet"},
        {"terms", {{{"target", "torque"}, {"basis", "sgn(w)*abs(theta_u)"}, {"coefficient", 0.01}, {"std_error", 2e-4}}}}};
    const dc::ModelCorrection c = dc::model_correction(read_model(model));
    ASSERT_EQ(c.terms.size(), 1u);
    const auto before = emadiag::estimate_physics(emadiag::check_run(run));
    const auto after = emadiag::estimate_physics(emadiag::check_run(dc::remove_model_effects(run, c)));
    const double r_before = diagnostic(before, "residual_scale_Nm");
    const double r_after = diagnostic(after, "residual_scale_Nm");
    std::cout << "residual scale " << r_before << " -> " << r_after << " N m; FDJ " << fdj(before) << " -> "
              << fdj(after) << " N m (truth " << kTrueFdjNm << ")\n";
    EXPECT_LT(r_after, 0.5 * r_before);
    EXPECT_LT(std::abs(fdj(after) - kTrueFdjNm), 0.5 * std::abs(fdj(before) - kTrueFdjNm));
    // On a run without the effect, the same model makes the residual worse: the test can fail.
    const emadiag::Run clean = run_with(sim::EmaParams::datasheet());
    EXPECT_GT(diagnostic(emadiag::estimate_physics(emadiag::check_run(dc::remove_model_effects(clean, c))), "residual_scale_Nm"),
              diagnostic(emadiag::estimate_physics(emadiag::check_run(clean)), "residual_scale_Nm"));
}

TEST(ModelCorrection, ALibraryEffectIsRemovedAsItsTerm) {
    sim::EmaParams truth = sim::EmaParams::datasheet();
    truth.effects.viscous_nm_s_rad = 8e-5;
    const emadiag::Run run = run_with(truth);
    const nlohmann::json model = {{"version", 1},
                                  {"base", "EMA-REF-1 datasheet"},
                                  {"terms", {{{"effect", "viscous_nm_s_rad"}, {"value", 8e-5}, {"std_error", 1e-6}}}}};
    const dc::ModelCorrection c = dc::model_correction(read_model(model));
    EXPECT_EQ(c.text(), "torque: 8e-05*w");
    const auto before = emadiag::estimate_physics(emadiag::check_run(run));
    const auto after = emadiag::estimate_physics(emadiag::check_run(dc::remove_model_effects(run, c)));
    EXPECT_LT(diagnostic(after, "residual_scale_Nm"), 0.5 * diagnostic(before, "residual_scale_Nm"));
    EXPECT_LT(std::abs(fdj(after) - kTrueFdjNm), 0.5 * std::abs(fdj(before) - kTrueFdjNm));
    // With typical noise, FDJ still moves back to the truth.
    const emadiag::Run noisy = run_with(truth, sim::NoiseProfile::Typical);
    const double fdj_before = fdj(emadiag::estimate_physics(emadiag::check_run(noisy)));
    const double fdj_after = fdj(emadiag::estimate_physics(emadiag::check_run(dc::remove_model_effects(noisy, c))));
    std::cout << "typical noise: FDJ " << fdj_before << " -> " << fdj_after << " N m (truth " << kTrueFdjNm << ")\n";
    EXPECT_LT(std::abs(fdj_after - kTrueFdjNm), 0.5 * std::abs(fdj_before - kTrueFdjNm));
}

TEST(ModelCorrection, SensorTermsAreInverted) {
    sim::EmaParams truth = sim::EmaParams::datasheet();
    truth.terms = {sim::parse_term("current: 0.15"), sim::parse_term("speed: 0.04*w")};
    const emadiag::Run run = run_with(truth, sim::NoiseProfile::None);
    const emadiag::Run clean = run_with(sim::EmaParams::datasheet(), sim::NoiseProfile::None);
    dc::ModelCorrection c;
    c.terms = truth.terms;
    const emadiag::Run back = dc::remove_model_effects(run, c);
    ASSERT_EQ(back.samples.size(), clean.samples.size());
    double worst_i = 0, worst_w = 0;
    for (std::size_t k = 0; k < back.samples.size(); ++k) {
        worst_i = std::max(worst_i, std::abs(back.samples[k].current_a - clean.samples[k].current_a));
        worst_w = std::max(worst_w, std::abs(back.samples[k].speed_rad_s - clean.samples[k].speed_rad_s) /
                                        std::max(1.0, std::abs(clean.samples[k].speed_rad_s)));
    }
    EXPECT_LT(worst_i, 1e-12);
    EXPECT_LT(worst_w, 1e-7);  // a 4 % gain after six fixed-point steps: 0.04^6 relative
}

TEST(ModelCorrection, BacklashAndAnInvalidModelAreClearErrors) {
    sim::EmaParams p = sim::EmaParams::datasheet();
    p.effects.backlash_rad = 0.002;
    EXPECT_THAT([&] { (void)dc::model_correction(p); }, ThrowsMessage<EmadiagError>(HasSubstr("backlash")));
    const nlohmann::json bad = {{"version", 1}, {"base", "EMA-REF-1 datasheet"},
                                {"terms", {{{"target", "torque"}, {"basis", "sgn(w)*nosuch(w)"}, {"coefficient", 1}}}}};
    sim::EmaParams q = sim::EmaParams::datasheet();
    EXPECT_THAT([&] { dc::apply_model(bad, q); }, ThrowsMessage<EmadiagError>(HasSubstr("model.terms[0]")));
    EXPECT_FALSE(dc::is_discovery_model(nlohmann::json{{"spec", 1}, {"weights", 2}}));
}

}  // namespace
