// SCG (Moller 1993 / MATLAB trainscg) on the paper's network: gradient against finite differences,
// convergence on small synthetic problems, validation stopping.
#include "estimation/eigen_dense.hpp"  // first: Eigen with its AVX-512 false positive scoped (see there)
#include "estimation/network.hpp"
#include "estimation/scg.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace emadiag {
namespace {

constexpr double kFiniteDifferenceStep = 1e-6;
constexpr double kGradientRelTolerance = 1e-5;

Eigen::MatrixXd random_matrix(int rows, int cols, std::mt19937_64& rng, double lo, double hi) {
    Eigen::MatrixXd m(rows, cols);
    for (int i = 0; i < rows; ++i)
        for (int k = 0; k < cols; ++k) m(i, k) = lo + (hi - lo) * static_cast<double>(rng() >> 11) * 0x1.0p-53;
    return m;
}

::testing::AssertionResult gradient_matches(const Network& net, const Eigen::MatrixXd& x, const Eigen::MatrixXd& t) {
    Eigen::VectorXd grad;
    (void)net.mse(x, t, &grad);
    Network probe = net;
    const Eigen::VectorXd w = net.flatten();
    for (Eigen::Index i = 0; i < w.size(); ++i) {
        Eigen::VectorXd wp = w, wm = w;
        wp(i) += kFiniteDifferenceStep;
        wm(i) -= kFiniteDifferenceStep;
        probe.unflatten(wp);
        const double fp = probe.mse(x, t);
        probe.unflatten(wm);
        const double fm = probe.mse(x, t);
        const double fd = (fp - fm) / (2 * kFiniteDifferenceStep);
        const double scale = std::max(1e-6, std::abs(fd) + std::abs(grad(i)));
        if (std::abs(fd - grad(i)) > kGradientRelTolerance * scale + 1e-10) {
            return ::testing::AssertionFailure() << "weight " << i << ": backprop " << grad(i) << " vs finite difference "
                                                 << fd;
        }
    }
    return ::testing::AssertionSuccess();
}

TEST(ScgTest, BackpropGradientMatchesFiniteDifferences) {
    const std::uint64_t seed = 20260101;
    std::cout << "seed " << seed << '\n';
    std::mt19937_64 rng(seed);
    Network net(7, 5, 2);
    net.initialise(seed);
    const Eigen::MatrixXd x = random_matrix(7, 13, rng, 0.0, 1.0);
    // Targets well inside (-1, 1) so that no output sits exactly at a satlins kink.
    const Eigen::MatrixXd t = random_matrix(2, 13, rng, -0.8, 0.8);
    EXPECT_TRUE(gradient_matches(net, x, t));
}

TEST(ScgTest, GradientIsZeroThroughSaturatedOutputs) {
    Network net(1, 1, 1);
    Eigen::VectorXd w(4);
    w << 1.0, 0.0, 10.0, 5.0;  // output = 10 tanh(x) + 5 >= 1 for x in [0, 1]: satlins clamps
    net.unflatten(w);
    Eigen::MatrixXd x(1, 3);
    x << 0.0, 0.5, 1.0;
    const Eigen::MatrixXd t = Eigen::MatrixXd::Zero(1, 3);
    Eigen::VectorXd grad;
    EXPECT_DOUBLE_EQ(net.mse(x, t, &grad), 1.0);
    EXPECT_DOUBLE_EQ(grad.norm(), 0.0);
}

TEST(ScgTest, MinimisesAQuadratic) {
    // f(x) = 1/2 x'Ax - b'x with A SPD: SCG reaches the minimum A^-1 b.
    Eigen::Matrix3d a;
    a << 4, 1, 0, 1, 3, 0.5, 0, 0.5, 2;
    const Eigen::Vector3d b(1, -2, 0.5);
    const ScgObjective f = [&](const Eigen::VectorXd& x, Eigen::VectorXd* g) {
        if (g != nullptr) *g = a * x - b;
        return 0.5 * x.dot(a * x) - b.dot(x);
    };
    ScgOptions o;
    o.goal = -1e300;  // the minimum is negative; stop on the gradient
    o.min_grad = 1e-6;  // MATLAB trainscg default
    const ScgResult r = train_scg(f, Eigen::VectorXd::Zero(3), o);
    const Eigen::Vector3d exact = a.ldlt().solve(b);
    EXPECT_LT((r.x - exact).norm(), 1e-6) << "stop " << r.stop_reason << " after " << r.epochs;
    EXPECT_EQ(r.stop_reason, "min_grad");
    EXPECT_LE(r.epochs, 6);  // conjugate directions: n = 3 steps, plus rounding
}

TEST(ScgTest, TrainsANetworkOnASmallSyntheticProblem) {
    const std::uint64_t seed = 7;
    std::cout << "seed " << seed << '\n';
    std::mt19937_64 rng(seed);
    const Eigen::MatrixXd x = random_matrix(3, 60, rng, 0.0, 1.0);
    Eigen::MatrixXd t(1, 60);
    for (int k = 0; k < 60; ++k) t(0, k) = 0.6 * std::sin(2.0 * x(0, k)) - 0.4 * x(1, k) * x(2, k);
    Network net(3, 8, 1);
    net.initialise(seed);
    const double start = net.mse(x, t);
    Network work = net;
    const ScgObjective f = [&](const Eigen::VectorXd& w, Eigen::VectorXd* g) {
        work.unflatten(w);
        return work.mse(x, t, g);
    };
    ScgOptions o;
    o.goal = 1e-6;
    const ScgResult r = train_scg(f, net.flatten(), o);
    EXPECT_LT(r.perf, 1e-4) << "from " << start << ", stop " << r.stop_reason << " after " << r.epochs;
    EXPECT_LT(r.perf, start / 100);
    EXPECT_EQ(r.perf_history.front(), start);
}

TEST(ScgTest, StopsAfterMaxFailValidationFailuresAndReturnsTheBest) {
    // A validation that only gets worse after epoch 3.
    const ScgObjective f = [](const Eigen::VectorXd& x, Eigen::VectorXd* g) {
        if (g != nullptr) *g = 2 * x;
        return x.squaredNorm() + 1.0;
    };
    int calls = 0;
    Eigen::VectorXd at_best;
    const ScgValidation v = [&](const Eigen::VectorXd& x) {
        ++calls;
        if (calls == 2) at_best = x;
        return calls == 2 ? 0.0 : 1.0 + calls;
    };
    ScgOptions o;
    o.goal = 0;
    o.min_grad = 0;
    o.max_fail = 12;
    Eigen::VectorXd x0(2);
    x0 << 3, -4;
    // The quadratic is solved in a few steps; afterwards the direction is zero. Use a harder one.
    const ScgObjective rosen = [](const Eigen::VectorXd& x, Eigen::VectorXd* g) {
        const double a = 1 - x(0), b = x(1) - x(0) * x(0);
        if (g != nullptr) {
            g->resize(2);
            (*g)(0) = -2 * a - 400 * x(0) * b;
            (*g)(1) = 200 * b;
        }
        return a * a + 100 * b * b;
    };
    (void)f;
    const ScgResult r = train_scg(rosen, x0, o, v);
    EXPECT_EQ(r.stop_reason, "validation");
    EXPECT_EQ(r.best_epoch, 1);
    EXPECT_EQ(r.epochs, 13);
    EXPECT_EQ(r.x, at_best);
}

TEST(ScgTest, RejectsNonPositiveSigma) {
    ScgOptions o;
    o.sigma = 0;
    const ScgObjective f = [](const Eigen::VectorXd& x, Eigen::VectorXd* g) {
        if (g != nullptr) *g = x;
        return 0.5 * x.squaredNorm();
    };
    EXPECT_THAT([&] { (void)train_scg(f, Eigen::VectorXd::Ones(2), o); },
                ::testing::ThrowsMessage<std::runtime_error>(::testing::HasSubstr("sigma")));
}

}  // namespace
}  // namespace emadiag
