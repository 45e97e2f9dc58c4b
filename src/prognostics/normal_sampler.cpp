#include "prognostics/normal_sampler.hpp"

#include <cmath>
#include <numbers>

namespace emadiag::prognostics {
namespace {
constexpr int kMantissaBits = 53;
constexpr double kTwoToMinus53 = 1.0 / 9007199254740992.0;  // 2^-53
}  // namespace

double NormalSampler::uniform() { return static_cast<double>(rng_() >> (64 - kMantissaBits)) * kTwoToMinus53; }

double NormalSampler::next() {
    if (has_spare_) {
        has_spare_ = false;
        return spare_;
    }
    const double u1 = 1.0 - uniform();  // (0, 1]: the logarithm stays finite
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    const double angle = 2.0 * std::numbers::pi * u2;
    spare_ = r * std::sin(angle);
    has_spare_ = true;
    return r * std::cos(angle);
}

}  // namespace emadiag::prognostics
