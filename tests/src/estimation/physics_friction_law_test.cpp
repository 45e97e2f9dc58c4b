// The uncertainty helpers of the friction law: the standard error of a uniform eta confound plus a
// Gaussian measurement error must give +/-1.96 se intervals that cover exactly 95 % (issue 4:
// calibrated uncertainty), in both limits and in between.
#include "estimation/physics_friction_law.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <iostream>
#include <random>

namespace emadiag {
namespace {

constexpr double kNinetyFive = 1.959963984540054;
constexpr double kLimitRelTolerance = 1e-9;
constexpr int kMonteCarloDraws = 400000;
constexpr double kCoverageTolerance = 0.002;  // binomial sd of the Monte Carlo is 0.00034

std::uint64_t test_seed() {
    const char* env = std::getenv("EMADIAG_TEST_SEED");
    return env ? std::strtoull(env, nullptr, 10) : 20240601ULL;
}

TEST(UniformPlusGaussianSe, ReducesToTheUniformAndTheGaussianLimits) {
    EXPECT_NEAR(uniform_plus_gaussian_se(0.01, 0.0), uniform_equivalent_se(0.01), kLimitRelTolerance * 0.01);
    EXPECT_NEAR(uniform_plus_gaussian_se(0.0, 0.003), 0.003, kLimitRelTolerance * 0.003);
    EXPECT_EQ(uniform_plus_gaussian_se(0.0, 0.0), 0.0);
}

TEST(UniformPlusGaussianSe, IsWiderThanTheQuadratureSumWhenBothPartsMatter) {
    const double h = 1.0, sigma = 0.4;
    EXPECT_GT(uniform_plus_gaussian_se(h, sigma), std::hypot(uniform_equivalent_se(h), sigma));
}

TEST(UniformPlusGaussianSe, CoversNinetyFivePercentOfTheSumByMonteCarlo) {
    const std::uint64_t seed = test_seed();
    std::cout << "seed " << seed << '\n';
    std::mt19937_64 rng(seed);
    for (const double ratio : {0.1, 0.3, 0.6, 1.0, 2.0}) {  // sigma / half-width
        const double h = 1.0, sigma = ratio * h;
        const double q = kNinetyFive * uniform_plus_gaussian_se(h, sigma);
        std::uniform_real_distribution<double> u(-h, h);
        std::normal_distribution<double> n(0.0, sigma);
        int inside = 0;
        for (int i = 0; i < kMonteCarloDraws; ++i) inside += std::abs(u(rng) + n(rng)) <= q ? 1 : 0;
        EXPECT_NEAR(static_cast<double>(inside) / kMonteCarloDraws, 0.95, kCoverageTolerance) << "sigma/h " << ratio;
    }
}

}  // namespace
}  // namespace emadiag
