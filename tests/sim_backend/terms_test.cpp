// Terms as data (terms.hpp, issue 10 part 2): parsed, written as JSON and read back, evaluated by
// the simulator on the scalar path and in simulate_batch's lanes (each lane its own terms).
#include "emadiag/sim/sim_error.hpp"
#include "emadiag/sim/simulator.hpp"
#include "emadiag/sim/terms.hpp"

#include "../../sim_backend/src/term_eval.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <random>

namespace emadiag::sim {
namespace {

SimConfig case_b_dyn() {
    SimConfig c;
    c.load_case = LoadCase::B;
    c.sequence = Sequence::Dyn;
    return c;
}

/// Restores the SIMD target (the widest, or EMADIAG_SIMD) when a test ends.
class SimdTargetGuard {
public:
    SimdTargetGuard() : saved_(simd_target().name) {}
    ~SimdTargetGuard() { set_simd_target(saved_); }
    SimdTargetGuard(const SimdTargetGuard&) = delete;
    SimdTargetGuard& operator=(const SimdTargetGuard&) = delete;

private:
    std::string saved_;
};

double max_speed_difference(const SimResult& a, const SimResult& b) {
    double d = 0;
    for (std::size_t k = 0; k < a.samples.size(); ++k) {
        d = std::max(d, std::abs(a.samples[k].speed_rad_s - b.samples[k].speed_rad_s));
    }
    return d;
}

TEST(Terms, ParseAndText) {
    const Term t = parse_term("torque: 0.02*sgn(w)*abs(theta_u)");
    EXPECT_EQ(t.target, TermTarget::Torque);
    EXPECT_DOUBLE_EQ(t.coefficient, 0.02);
    ASSERT_EQ(t.factors.size(), 2u);
    EXPECT_EQ(t.factors[0].basis, TermBasis::Sgn);
    EXPECT_EQ(t.factors[1].signal, TermSignal::ThetaSurface);
    EXPECT_EQ(t.text(), "torque: 0.02*sgn(w)*abs(theta_u)");
    const Term g = parse_term("current: -0.05");
    EXPECT_EQ(g.target, TermTarget::Current);
    EXPECT_TRUE(g.factors.empty());
    const Term p = parse_term("0.01*gauss(theta_u, -4, 1.5)*sin(theta_m, 0.7)");
    EXPECT_EQ(p.factors[0].basis, TermBasis::Gauss);
    EXPECT_DOUBLE_EQ(p.factors[0].a, -4);
    EXPECT_DOUBLE_EQ(p.factors[0].b, 1.5);
    TermInputs x;
    x.theta_u_deg = -4;
    x.theta_m = 0.7 / 4;
    EXPECT_NEAR(term_value(p, x), 0.01, 1e-12);
}

TEST(Terms, ParseErrorsNameWhatAndWhere) {
    auto message = [](const std::string& s) {
        try {
            (void)parse_term(s);
        } catch (const SimError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_NE(message("torque: 0.1*sgn(v)").find("expected a signal"), std::string::npos) << message("torque: 0.1*sgn(v)");
    EXPECT_NE(message("force: 0.1").find("a target"), std::string::npos);
    EXPECT_NE(message("0.1*sin(w, 0)").find("period must be > 0"), std::string::npos);
    EXPECT_NE(message("0.1*foo(w)").find("a function"), std::string::npos);
    EXPECT_NE(message("0.1 w").find("'*'"), std::string::npos);
}

TEST(Terms, JsonRoundTripThroughParams) {
    EmaParams p = EmaParams::datasheet();
    p.terms.push_back(parse_term("torque: 0.03*sgn(w)*abs(F_R)"));
    p.terms.push_back(parse_term("theta: 0.02*t"));
    p.terms[0].std_error = 0.001;
    const EmaParams q = EmaParams::from_json(p.to_json());
    ASSERT_EQ(q.terms.size(), 2u);
    EXPECT_EQ(q.terms[0].text(), p.terms[0].text());
    EXPECT_DOUBLE_EQ(q.terms[0].std_error, 0.001);
    EXPECT_EQ(q.terms[1].target, TermTarget::Theta);
    // The datasheet writes no "terms" key; a bad term is an error naming where it is.
    EXPECT_FALSE(EmaParams::datasheet().to_json().contains("terms"));
    nlohmann::json bad = EmaParams::datasheet().to_json();
    bad["terms"] = {{{"basis", "sgn(q)"}, {"coefficient", 1.0}}};
    try {
        (void)EmaParams::from_json(bad);
        FAIL() << "no error";
    } catch (const SimError& e) {
        EXPECT_NE(std::string(e.what()).find("params.terms[0]"), std::string::npos) << e.what();
    }
}

TEST(Terms, TorqueTermActsLikeTheEffectItWrites) {
    // viscous friction as an effect and as the term 5e-5 * w: the same motion.
    SimConfig a = case_b_dyn();
    a.params.effects.set("viscous", 5e-5);
    SimConfig b = case_b_dyn();
    b.params.terms.push_back(parse_term("torque: 5e-5*w"));
    const SimResult ra = simulate(a), rb = simulate(b), r0 = simulate(case_b_dyn());
    EXPECT_LT(max_speed_difference(ra, rb), 0.05);
    EXPECT_GT(max_speed_difference(ra, r0), 1.0);  // and the term did change the run
}

TEST(Terms, SensorTermsChangeOnlyTheReportedSignal) {
    SimConfig a = case_b_dyn();
    a.params.terms.push_back(parse_term("current: 0.05"));
    a.params.terms.push_back(parse_term("theta: 0.02*t"));
    const SimResult r = simulate(a), r0 = simulate(case_b_dyn());
    for (std::size_t k = 0; k < r.samples.size(); ++k) {
        EXPECT_NEAR(r.samples[k].current_a - r0.samples[k].current_a, 0.05, 1e-12);
        EXPECT_NEAR(r.samples[k].theta_m_rad - r0.samples[k].theta_m_rad, 0.02 * r0.samples[k].t_s, 1e-12);
        EXPECT_EQ(r.samples[k].speed_rad_s, r0.samples[k].speed_rad_s);
    }
}

TEST(Terms, BatchRunsTermsInItsLanesWithTheScalarPathsResults) {
    std::vector<SimConfig> cs(3, case_b_dyn());
    for (std::size_t i = 0; i < cs.size(); ++i) {
        cs[i].params.terms.push_back(parse_term("torque: 0.04*sgn(w)*abs(theta_u)"));
        cs[i].params.fdj_nm = 0.06 + 0.01 * static_cast<double>(i);
    }
    const auto rs = simulate_batch(cs, 1);
    for (std::size_t i = 0; i < cs.size(); ++i) {
        const SimResult one = simulate(cs[i]);
        EXPECT_EQ(max_speed_difference(rs[i], one), 0.0);
    }
    // Lanes with different terms, or none, in one batch.
    std::vector<SimConfig> mixed = {cs[0], case_b_dyn(), cs[1]};
    mixed[2].params.terms[0] = parse_term("torque: 0.02*sin(theta_u, 5)");
    const auto rm = simulate_batch(mixed, 1);
    for (std::size_t i = 0; i < mixed.size(); ++i) EXPECT_EQ(max_speed_difference(rm[i], simulate(mixed[i])), 0.0) << "lane " << i;
}

// Periodic bases (term_eval.hpp: fdlibm's kernels, not the C library's calls) are within 1 ulp of
// std::sin / std::cos, over the range the signals take and beyond it (there the C library is used).
TEST(Terms, PeriodicBasesAreWithinOneUlpOfTheCLibrary) {
    constexpr std::uint64_t kSeed = 20261125;
    std::printf("seed %llu\n", static_cast<unsigned long long>(kSeed));
    std::mt19937_64 g(kSeed);
    Term s = parse_term("torque: 1*sin(t, 1)");
    Term c = parse_term("torque: 1*cos(t, 1)");
    auto ulps = [](double got, double want) {
        if (got == want) return 0.0;
        const double ulp = std::nextafter(std::abs(want), INFINITY) - std::abs(want);
        return std::abs(got - want) / ulp;
    };
    double worst = 0;
    for (const double range : {0.3, 3.0, 300.0, 3e5, 3e7}) {
        std::uniform_real_distribution<double> u(-range, range);
        for (int k = 0; k < 20000; ++k) {
            TermInputs x;
            x.t = u(g);
            const double arg = 2.0 * std::numbers::pi * x.t / 1.0;
            worst = std::max({worst, ulps(term_basis(s, x), std::sin(arg)), ulps(term_basis(c, x), std::cos(arg))});
            ASSERT_LE(worst, 1.0) << "t = " << x.t << " (seed " << kSeed << ")";
        }
    }
    // Arguments next to multiples of pi/2, where the reduction cancels.
    for (int k = -2000; k <= 2000; ++k) {
        TermInputs x;
        x.t = k * 0.25;
        for (int d = 0; d < 4; ++d) {
            const double arg = 2.0 * std::numbers::pi * x.t / 1.0;
            EXPECT_LE(ulps(term_basis(s, x), std::sin(arg)), 1.0) << "t = " << x.t;
            EXPECT_LE(ulps(term_basis(c, x), std::cos(arg)), 1.0) << "t = " << x.t;
            x.t = std::nextafter(x.t, INFINITY);
        }
    }
}

// Lanes full of periodic terms (sin/cos pairs in both angles, a product with a bump, time) over two
// vectors, and a batch with more periodic factors than one step gathers (evaluated lane by lane):
// each lane has the scalar path's result bit for bit.
TEST(Terms, BatchRunsManyPeriodicTermsWithTheScalarPathsResults) {
    const std::vector<std::string> texts = {"torque: 0.03*sin(theta_u, 5)", "torque: -0.02*cos(theta_u, 5)",
                                            "torque: 0.02*sin(theta_m, 40)", "torque: 0.01*cos(theta_m, 40)",
                                            "torque: 0.02*gauss(theta_u, -3, 2)*sin(t, 0.05)",
                                            "torque: 0.01*sgn(w)*cos(w, 300)"};
    for (const std::size_t copies : {std::size_t{1}, std::size_t{3}}) {
        std::vector<SimConfig> cs(9, case_b_dyn());
        for (std::size_t i = 0; i < cs.size(); ++i) {
            for (std::size_t r = 0; r < copies; ++r) {
                for (const auto& t : texts) cs[i].params.terms.push_back(parse_term(t));
            }
            cs[i].params.terms[i % texts.size()].coefficient *= 1.5;
            cs[i].params.fdj_nm = 0.06 + 0.005 * static_cast<double>(i);
        }
        cs[4].params.terms.clear();  // a lane without terms between lanes with them
        // On every instruction set the CPU has (the periodic factors' sin and cos are dispatched
        // with the step), against the scalar path of the baseline build.
        const SimdTargetGuard guard;
        set_simd_target("scalar");
        std::vector<SimResult> scalar;
        for (std::size_t i = 0; i < cs.size(); i += 2) scalar.push_back(simulate(cs[i]));
        for (const std::string& target : supported_simd_targets()) {
            set_simd_target(target);
            const auto rs = simulate_batch(cs, 1);
            for (std::size_t i = 0; i < cs.size(); i += 2) {
                EXPECT_EQ(max_speed_difference(rs[i], scalar[i / 2]), 0.0)
                    << "lane " << i << ", copies " << copies << ", target " << target;
            }
        }
    }
}

// term_sincos_many (Highway, one copy per instruction set) gives term_sincos's bits for every
// argument, on every target the CPU has: random arguments over the signals' range and beyond the
// medium range (the C library's there), signed zeros, subnormals, infinities, NaN, neighbours of
// multiples of pi/2, and every count from 1 to 19 (whole vectors and a partial last one).
TEST(Terms, SinCosOfManyArgumentsGivesTermSinCosBitsOnEverySupportedTarget) {
    constexpr std::uint64_t kSeed = 20261126;
    std::printf("seed %llu\n", static_cast<unsigned long long>(kSeed));
    std::mt19937_64 g(kSeed);
    std::vector<double> x = {0.0, -0.0, 4.9e-324, -4.9e-324, 2.2250738585072014e-308, 1e-300, 1.0, -1.0,
                             detail::kTrigMediumMax, -detail::kTrigMediumMax, std::nextafter(detail::kTrigMediumMax, INFINITY),
                             1e7, -3e9, 1e300, std::numeric_limits<double>::max(), INFINITY, -INFINITY,
                             std::numeric_limits<double>::quiet_NaN()};
    for (int k = -400; k <= 400; ++k) {
        const double m = k * (std::numbers::pi / 2.0);
        x.insert(x.end(), {m, std::nextafter(m, INFINITY), std::nextafter(m, -INFINITY)});
    }
    for (const double range : {0.5, 10.0, 1e4, 1.5e6, 1e8}) {
        std::uniform_real_distribution<double> u(-range, range);
        for (int k = 0; k < 4000; ++k) x.push_back(u(g));
    }
    std::vector<double> want_s(x.size()), want_c(x.size());
    for (std::size_t k = 0; k < x.size(); ++k) detail::term_sincos(x[k], want_s[k], want_c[k]);
    const auto bits = [](double v) { return std::bit_cast<std::uint64_t>(v); };
    const SimdTargetGuard guard;
    for (const std::string& target : supported_simd_targets()) {
        set_simd_target(target);
        std::vector<double> s(x.size()), c(x.size());
        detail::term_sincos_many(x.data(), s.data(), c.data(), static_cast<int>(x.size()));
        for (std::size_t k = 0; k < x.size(); ++k) {
            ASSERT_EQ(bits(s[k]), bits(want_s[k])) << "sin(" << x[k] << ") on " << target << " (seed " << kSeed << ")";
            ASSERT_EQ(bits(c[k]), bits(want_c[k])) << "cos(" << x[k] << ") on " << target << " (seed " << kSeed << ")";
        }
        for (int n = 1; n <= 19; ++n) {  // counts that end in a partial vector; the rest left untouched
            std::vector<double> sn(20, 7.0), cn(20, 7.0);
            detail::term_sincos_many(x.data() + 1000, sn.data(), cn.data(), n);
            for (int k = 0; k < 20; ++k) {
                EXPECT_EQ(bits(sn[k]), bits(k < n ? want_s[1000 + k] : 7.0)) << "n " << n << " k " << k << " on " << target;
                EXPECT_EQ(bits(cn[k]), bits(k < n ? want_c[1000 + k] : 7.0)) << "n " << n << " k " << k << " on " << target;
            }
        }
    }
}

}  // namespace
}  // namespace emadiag::sim
