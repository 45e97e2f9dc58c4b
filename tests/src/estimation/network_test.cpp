// The paper's network: satlins/tansig, resampling, features, JSON round trip, and the shipped
// models (models/*.json) loading and predicting simulated runs.
#include "estimation/network.hpp"
#include "estimation/network_model.hpp"

#include "core/sim_run.hpp"
#include "estimation/dataset.hpp"
#include "emadiag/sim/simulator.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace emadiag {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

TEST(NetworkTest, SatlinsClampsToMinusOneOne) {
    EXPECT_EQ(satlins(-3.0), -1.0);
    EXPECT_EQ(satlins(-1.0), -1.0);
    EXPECT_EQ(satlins(-0.25), -0.25);
    EXPECT_EQ(satlins(0.0), 0.0);
    EXPECT_EQ(satlins(0.7), 0.7);
    EXPECT_EQ(satlins(1.0), 1.0);
    EXPECT_EQ(satlins(42.0), 1.0);
}

TEST(NetworkTest, TansigIsMatlabFormula) {
    for (double n : {-3.0, -0.5, 0.0, 0.1, 2.0}) {
        EXPECT_NEAR(tansig(n), 2.0 / (1.0 + std::exp(-2.0 * n)) - 1.0, 1e-15) << "n = " << n;
    }
}

TEST(NetworkTest, ForwardClampsOutputsSoPredictionsStayInZeroOne) {
    Network net(2, 1, 2);
    Eigen::VectorXd w(2 + 1 + 2 + 2);
    // hidden = tanh(x0 + x1); outputs 5 h + 0 and -5 h + 0.1
    w << 1, 1, 0, 5, -5, 0, 0.1;
    net.unflatten(w);
    Eigen::MatrixXd x(2, 2);
    x << 1, 0, 1, 0;
    const Eigen::MatrixXd y = net.forward(x);
    EXPECT_EQ(y(0, 0), 1.0);   // 5 tanh(2) clamped
    EXPECT_EQ(y(1, 0), -1.0);  // -5 tanh(2) + 0.1 clamped
    EXPECT_EQ(y(0, 1), 0.0);
    EXPECT_DOUBLE_EQ(y(1, 1), 0.1);
    EXPECT_EQ(from_internal(y(0, 0)), 1.0);
    EXPECT_EQ(from_internal(y(1, 0)), 0.0);
}

TEST(NetworkTest, FlattenUnflattenAndJsonRoundTrip) {
    Network net(4, 3, 2);
    net.initialise(99);
    const Eigen::VectorXd w = net.flatten();
    EXPECT_EQ(w.size(), 4 * 3 + 3 + 3 * 2 + 2);
    Network back = Network::from_json(net.to_json(), "net");
    EXPECT_EQ(back.flatten(), w);
    EXPECT_THAT([&] { net.unflatten(Eigen::VectorXd::Zero(3)); },
                ThrowsMessage<std::runtime_error>(HasSubstr("weight vector has 3 values, the network 23")));
}

// Network::mse with an MseCache (SCG's error at a trial point, then its gradient there): the cached
// forward pass gives the uncached result bit for bit, and is used only for the same weights and inputs.
TEST(NetworkTest, MseWithACachedForwardPassIsBitForBitTheUncachedOne) {
    Network net(7, 5, 2);
    net.initialise(11);
    Eigen::MatrixXd x(7, 9), t(2, 9), x2(7, 9);
    for (Eigen::Index j = 0; j < x.cols(); ++j) {
        for (Eigen::Index i = 0; i < x.rows(); ++i) {
            x(i, j) = std::sin(0.7 * static_cast<double>(i) + 1.3 * static_cast<double>(j));
            x2(i, j) = x(i, j) * 0.5;
        }
        t(0, j) = 0.3 * std::cos(static_cast<double>(j));
        t(1, j) = -0.2;
    }
    Eigen::VectorXd want_grad, grad;
    const double want = net.mse(x, t, &want_grad);
    MseCache cache;
    EXPECT_EQ(net.mse(x, t, nullptr, &cache), want);  // fills the cache
    EXPECT_EQ(cache.hits, 0);
    EXPECT_EQ(net.mse(x, t, &grad, &cache), want);  // the same point: its forward pass from the cache
    EXPECT_EQ(cache.hits, 1);
    EXPECT_EQ(grad, want_grad);
    // Other inputs, or other weights: computed afresh.
    EXPECT_EQ(net.mse(x2, t, &grad, &cache), net.mse(x2, t));
    EXPECT_EQ(cache.hits, 1);
    Eigen::VectorXd w = net.flatten();
    w[3] += 1e-3;
    net.unflatten(w);
    const double moved = net.mse(x2, t, &want_grad);
    EXPECT_EQ(net.mse(x2, t, &grad, &cache), moved);
    EXPECT_EQ(grad, want_grad);
    EXPECT_EQ(cache.hits, 1);
}

// The network's kernels give the same doubles wherever their inputs sit on the heap: Eigen peels its
// reductions and products by the data's alignment, so every Eigen allocation is aligned to the widest
// vector (EIGEN_MAX_ALIGN_BYTES, set for the whole build). Without that, a training's last bits
// depended on the heap layout (even on the length of an --out path). Each supported target in turn,
// with copies of the same network and data placed after paddings of 1 to 7 doubles.
TEST(NetworkTest, MseAndGradientDoNotDependOnWhereTheDataSits) {
    const std::string saved = sim::simd_target().name;
    constexpr int kInputs = 60, kHidden = 20, kOutputs = 3, kCols = 75;
    Network net(kInputs, kHidden, kOutputs);
    net.initialise(5);
    Eigen::MatrixXd x(kInputs, kCols), t(kOutputs, kCols);
    for (Eigen::Index j = 0; j < kCols; ++j) {
        for (Eigen::Index i = 0; i < kInputs; ++i) {
            x(i, j) = std::sin(0.37 * static_cast<double>(i) + 1.71 * static_cast<double>(j));
        }
        for (Eigen::Index i = 0; i < kOutputs; ++i) t(i, j) = 0.4 * std::cos(static_cast<double>(i + 3 * j));
    }
    for (const std::string& target : sim::supported_simd_targets()) {
        sim::set_simd_target(target);
        Eigen::VectorXd want_grad;
        const double want = net.mse(x, t, &want_grad);
        const Eigen::MatrixXd want_y = net.forward(x);
        std::vector<std::vector<double>> paddings;
        for (int pad = 1; pad <= 7; ++pad) {
            paddings.emplace_back(static_cast<std::size_t>(pad), 0.0);  // moves the next allocations
            const Network copy = Network::from_json(net.to_json(), "copy");
            const Eigen::MatrixXd x_copy = x, t_copy = t;
            Eigen::VectorXd grad;
            EXPECT_EQ(copy.mse(x_copy, t_copy, &grad), want) << target << ", padding " << pad;
            EXPECT_EQ(grad, want_grad) << target << ", padding " << pad;
            EXPECT_EQ(copy.forward(x_copy), want_y) << target << ", padding " << pad;
            EXPECT_EQ(reinterpret_cast<std::uintptr_t>(x_copy.data()) % EIGEN_MAX_ALIGN_BYTES, 0U) << target;
        }
    }
    sim::set_simd_target(saved);
}

TEST(NetworkTest, InitialisationIsSeeded) {
    Network a(5, 4, 1), b(5, 4, 1), c(5, 4, 1);
    a.initialise(3);
    b.initialise(3);
    c.initialise(4);
    EXPECT_EQ(a.flatten(), b.flatten());
    EXPECT_NE(a.flatten(), c.flatten());
}

TEST(NetworkTest, ResampleLinearInterpolatesAndKeepsEnds) {
    const std::vector<double> t = {0.0, 1.0, 2.0, 4.0};
    const std::vector<double> y = {0.0, 10.0, 20.0, 0.0};
    const auto r = resample_linear(t, y, 5);  // 0, 1, 2, 3, 4
    ASSERT_EQ(r.size(), 5u);
    EXPECT_DOUBLE_EQ(r[0], 0.0);
    EXPECT_DOUBLE_EQ(r[1], 10.0);
    EXPECT_DOUBLE_EQ(r[2], 20.0);
    EXPECT_DOUBLE_EQ(r[3], 10.0);
    EXPECT_DOUBLE_EQ(r[4], 0.0);
    EXPECT_THAT([&] { (void)resample_linear(t, y, 1); }, ThrowsMessage<std::runtime_error>(HasSubstr("n 1 is below 2")));
}

TEST(NetworkTest, ResampleMeanAveragesEachWindow) {
    std::vector<double> t(9), y(9);
    for (int i = 0; i < 9; ++i) {
        t[static_cast<std::size_t>(i)] = i;                    // 0 .. 8
        y[static_cast<std::size_t>(i)] = i % 2 == 0 ? 1 : -1;  // alternating "noise"
    }
    const auto r = resample_mean(t, y, 3);  // points 0, 4, 8; windows [-2, 2), [2, 6), [6, 10)
    ASSERT_EQ(r.size(), 3u);
    EXPECT_DOUBLE_EQ(r[0], 0.0);         // samples 0, 1
    EXPECT_DOUBLE_EQ(r[1], 0.0);         // samples 2..5
    EXPECT_DOUBLE_EQ(r[2], 1.0 / 3.0);   // samples 6, 7, 8
    // More points than samples: empty windows fall back to linear interpolation.
    const auto fine = resample_mean({0.0, 1.0}, {0.0, 2.0}, 5);
    EXPECT_DOUBLE_EQ(fine[1], 0.5);
    NetworkSpec spec;
    spec.outputs = {kParamFdj};
    nlohmann::json j = spec.to_json();
    j["resample"] = "cubic";
    EXPECT_THAT([&] { (void)NetworkSpec::from_json(j, "spec"); },
                ThrowsMessage<std::runtime_error>(HasSubstr("spec: resample 'cubic' is not 'linear' or 'mean'")));
}

TEST(NetworkTest, InputNormalisationMapsTrainingRangeToZeroOne) {
    Eigen::MatrixXd x(2, 3);
    x << 1, 2, 3, 5, 5, 5;
    const InputNormalisation n = InputNormalisation::fit(x);
    const Eigen::MatrixXd u = n.apply(x);
    EXPECT_DOUBLE_EQ(u(0, 0), 0.0);
    EXPECT_DOUBLE_EQ(u(0, 1), 0.5);
    EXPECT_DOUBLE_EQ(u(0, 2), 1.0);
    EXPECT_DOUBLE_EQ(u(1, 1), 0.0);  // constant input
}

TEST(NetworkTest, FeaturesHaveTimestepsPerSignal) {
    sim::SimConfig c;
    c.load_case = sim::LoadCase::B;
    const emadiag::Run run = make_run(c, sim::simulate(c));
    NetworkSpec spec;
    spec.timesteps = 100;
    spec.with_speed = true;
    spec.with_load = true;
    spec.outputs = {kParamFdj};
    const Eigen::VectorXd x = network_features(run, spec);
    ASSERT_EQ(x.size(), 300);
    // The speed block ends at the last sample's speed, the load block at the last F_R.
    EXPECT_DOUBLE_EQ(x(199), run.samples.back().speed_rad_s);
    EXPECT_DOUBLE_EQ(x(299), run.samples.back().hinge_moment_nm / run.constants.tau);
}

// ---- shipped models
struct ShippedModel {
    const char* file;
    sim::LoadCase load_case;
    sim::NoiseProfile noise;
};

std::string model_path(const char* file) { return std::string(EMADIAG_SOURCE_DIR) + "/models/" + file; }

class ShippedModelTest : public ::testing::TestWithParam<ShippedModel> {};

TEST_P(ShippedModelTest, LoadsAndPredictsASimulatedRunWithinItsUncertainty) {
    const ShippedModel m = GetParam();
    const NetworkModel model = NetworkModel::load(model_path(m.file));
    EXPECT_EQ(model.spec.load_case, m.load_case);
    // A run the model never saw, at an off-nominal health state.
    sim::SimConfig c;
    c.load_case = m.load_case;
    c.params.fdj_nm = 0.0712;
    c.params.fsj_nm = 0.131;
    c.params.eta_o = 0.87;
    c.params.eta_a = sim::eta_a_from_eta_o(c.params.eta_o, c.params.tau);
    c.noise = m.noise;
    c.seed = 77;
    const emadiag::Run run = make_run(c, sim::simulate(c));
    const HealthEstimate h = model.estimate(run);
    EXPECT_THAT(h.find(kParamFdj)->note, ::testing::Not(HasSubstr("understated")));
    EXPECT_EQ(to_string(h.estimator), "network");
    ASSERT_EQ(h.parameters.size(), 4u);
    // Within 4 calibrated standard errors (a 95 % interval is 1.96).
    constexpr double kSigmas = 4.0;
    const ParameterEstimate* fdj = h.find(kParamFdj);
    ASSERT_TRUE(fdj != nullptr && fdj->value);
    EXPECT_GT(fdj->std_error, 0.0);
    EXPECT_NEAR(*fdj->value, c.params.fdj_nm, kSigmas * fdj->std_error) << m.file;
    const ParameterEstimate* fsj = h.find(kParamFsj);
    ASSERT_NE(fsj, nullptr);
    EXPECT_FALSE(fsj->identifiable);
    EXPECT_FALSE(fsj->value);
    EXPECT_THAT(fsj->note, HasSubstr("not identifiable"));
    const ParameterEstimate* eta_o = h.find(kParamEtaO);
    ASSERT_NE(eta_o, nullptr);
    if (m.load_case == sim::LoadCase::A) {
        EXPECT_FALSE(eta_o->identifiable);
        EXPECT_FALSE(eta_o->value);
    } else {
        ASSERT_TRUE(eta_o->value);
        EXPECT_NEAR(*eta_o->value, c.params.eta_o, kSigmas * eta_o->std_error) << m.file;
        const ParameterEstimate* eta_a = h.find(kParamEtaA);
        ASSERT_TRUE(eta_a != nullptr && eta_a->value);
        EXPECT_NEAR(*eta_a->value, c.params.eta_a, kSigmas * eta_a->std_error) << m.file;
    }
}

INSTANTIATE_TEST_SUITE_P(Models, ShippedModelTest,
                         ::testing::Values(ShippedModel{"case_a.json", sim::LoadCase::A, sim::NoiseProfile::None},
                                           ShippedModel{"case_a_ext.json", sim::LoadCase::AExt, sim::NoiseProfile::None},
                                           ShippedModel{"case_b.json", sim::LoadCase::B, sim::NoiseProfile::None},
                                           ShippedModel{"case_a_typical.json", sim::LoadCase::A, sim::NoiseProfile::Typical},
                                           ShippedModel{"case_a_ext_typical.json", sim::LoadCase::AExt,
                                                        sim::NoiseProfile::Typical},
                                           ShippedModel{"case_b_typical.json", sim::LoadCase::B, sim::NoiseProfile::Typical}));

TEST(NetworkModelTest, NotesANoiseMismatch) {
    const NetworkModel model = NetworkModel::load(model_path("case_b.json"));
    sim::SimConfig c;
    c.noise = sim::NoiseProfile::Typical;
    const HealthEstimate h = model.estimate(make_run(c, sim::simulate(c)));
    EXPECT_THAT(h.find(kParamFdj)->note, HasSubstr("model trained on noise none, the run declares noise typical"));
}

TEST(NetworkModelTest, RejectsARunOfAnotherCase) {
    const NetworkModel model = NetworkModel::load(model_path("case_b.json"));
    sim::SimConfig c;
    c.load_case = sim::LoadCase::A;
    const emadiag::Run run = make_run(c, sim::simulate(c));
    EXPECT_THAT([&] { (void)model.estimate(run); },
                ThrowsMessage<std::runtime_error>(HasSubstr("trained on case B, sequence dyn; the run is case A")));
}

TEST(NetworkModelTest, LoadNamesTheFileAndField) {
    EXPECT_THAT([] { (void)NetworkModel::load("/nonexistent/model.json"); },
                ThrowsMessage<std::runtime_error>(HasSubstr("cannot open network model /nonexistent/model.json")));
    nlohmann::json j = NetworkModel::load(model_path("case_b.json")).to_json();
    j["version"] = 99;
    EXPECT_THAT([&] { (void)NetworkModel::from_json(j, "m.json"); },
                ThrowsMessage<std::runtime_error>(HasSubstr("m.json: field version 99 is not supported")));
}

}  // namespace
}  // namespace emadiag
