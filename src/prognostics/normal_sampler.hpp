#pragma once
// Standard normal draws that are the same on every standard library: the Box-Muller transform on
// std::mt19937_64 (standard distributions differ between libraries; the engine does not).
#include <cstdint>
#include <random>

namespace emadiag::prognostics {

class NormalSampler {
public:
    explicit NormalSampler(std::uint64_t seed) : rng_(seed), seed_(seed) {}

    /// One N(0, 1) draw. Box-Muller: z0 = sqrt(-2 ln u1) cos(2 pi u2), z1 = sqrt(-2 ln u1) sin(2 pi u2)
    /// for independent u1 in (0, 1], u2 in [0, 1); z1 is kept for the next call.
    [[nodiscard]] double next();
    /// A uniform draw in [0, 1) with 53 random bits.
    [[nodiscard]] double uniform();
    [[nodiscard]] std::uint64_t seed() const { return seed_; }

private:
    std::mt19937_64 rng_;
    std::uint64_t seed_;
    double spare_ = 0;
    bool has_spare_ = false;
};

}  // namespace emadiag::prognostics
