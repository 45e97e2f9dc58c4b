// Datasets: section-8 sampling, determinism, the bad-simulation filter, the file format, the split.
#include "estimation/dataset.hpp"

#include "core/residual_torque.hpp"
#include "estimation/health_estimate.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <set>

namespace emadiag {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

std::string temp_path(const std::string& name) {
    return std::string(EMADIAG_BINARY_DIR) + "/dataset_test_" + name;
}

TEST(DatasetTest, RangesAreSectionEight) {
    EXPECT_DOUBLE_EQ(health_range(kParamFdj).lo, 0.064);
    EXPECT_DOUBLE_EQ(health_range(kParamFdj).hi, 0.096);
    EXPECT_DOUBLE_EQ(health_range(kParamFsj).lo, 0.096);
    EXPECT_DOUBLE_EQ(health_range(kParamFsj).hi, 0.144);
    EXPECT_NEAR(health_range(kParamEtaA).lo, 0.659031, 1e-6);
    EXPECT_NEAR(health_range(kParamEtaA).hi, 0.988546, 1e-6);
    // eta_O's range is the eq. (4) image of eta_A's; nominal maps to 0.5 for eta_A.
    EXPECT_NEAR(sim::eta_a_from_eta_o(health_range(kParamEtaO).lo, 800.0), health_range(kParamEtaA).lo, 1e-12);
    EXPECT_NEAR(health_range(kParamEtaA).normalise(0.823788), 0.5, 1e-6);
    EXPECT_THAT([] { (void)health_range("FOO"); }, ThrowsMessage<std::runtime_error>(HasSubstr("unknown health parameter 'FOO'")));
}

TEST(DatasetTest, LabelsAreUniformInRangeAndSeeded) {
    const std::uint64_t seed = 424242;
    std::cout << "seed " << seed << '\n';
    std::mt19937_64 a(seed), b(seed);
    constexpr int kDraws = 4000;
    double mean_u = 0;
    for (int i = 0; i < kDraws; ++i) {
        const HealthLabels h = draw_health_labels(a, 800.0);
        const HealthLabels g = draw_health_labels(b, 800.0);
        ASSERT_EQ(h.fdj_nm, g.fdj_nm);
        for (const char* p : {kParamFdj, kParamFsj, kParamEtaA, kParamEtaO}) {
            const double u = health_range(p).normalise(h.get(p));
            ASSERT_GE(u, -1e-12) << p;
            ASSERT_LE(u, 1.0 + 1e-12) << p;
        }
        EXPECT_NEAR(sim::eta_a_from_eta_o(h.eta_o, 800.0), h.eta_a, 1e-12);
        mean_u += health_range(kParamFdj).normalise(h.fdj_nm);
    }
    EXPECT_NEAR(mean_u / kDraws, 0.5, 0.02);  // 4.6 sigma of a uniform mean over 4000 draws
}

TEST(DatasetTest, GenerationIsDeterministicAndFilters) {
    DatasetSpec spec;
    spec.load_case = sim::LoadCase::B;
    spec.count = 10;
    spec.seed = 5;
    spec.noise = sim::NoiseProfile::Typical;
    const Dataset a = generate_dataset(spec, 2);
    const Dataset b = generate_dataset(spec, 1);
    ASSERT_EQ(a.runs.size(), 10u);
    EXPECT_EQ(a.filter.simulated, 10);
    EXPECT_EQ(a.filter.accepted, 10);
    for (std::size_t i = 0; i < a.runs.size(); ++i) {
        EXPECT_EQ(a.runs[i].labels.fdj_nm, b.runs[i].labels.fdj_nm);
        EXPECT_EQ(a.runs[i].samples.size(), 1000u);
        EXPECT_EQ(a.runs[i].samples[500].current_a, b.runs[i].samples[500].current_a);
    }
    // Runs expose analysis metadata only.
    const emadiag::Run r = a.run(3);
    EXPECT_FALSE(r.meta_value("true_FDJ_Nm"));
    EXPECT_EQ(r.load_case, emadiag::sim::LoadCase::B);
    EXPECT_EQ(*r.meta_value("noise"), "typical");
}

TEST(DatasetTest, WithNoiseMatchesGeneratingWithNoise) {
    DatasetSpec spec;
    spec.load_case = sim::LoadCase::AExt;
    spec.count = 3;
    spec.seed = 8;
    const Dataset clean = generate_dataset(spec, 2);
    spec.noise = sim::NoiseProfile::Typical;
    const Dataset noisy = generate_dataset(spec, 2);
    const Dataset derived = clean.with_noise(sim::NoiseProfile::Typical);
    ASSERT_EQ(noisy.runs.size(), derived.runs.size());
    for (std::size_t i = 0; i < noisy.runs.size(); ++i) {
        EXPECT_EQ(noisy.runs[i].samples[10].speed_rad_s, derived.runs[i].samples[10].speed_rad_s);
        EXPECT_NE(clean.runs[i].samples[10].speed_rad_s, derived.runs[i].samples[10].speed_rad_s);
    }
    EXPECT_THAT([&] { (void)noisy.with_noise(sim::NoiseProfile::Typical); },
                ThrowsMessage<std::runtime_error>(HasSubstr("needs a noiseless dataset")));
}

TEST(DatasetTest, FilterClassifiesBadSimulations) {
    const sim::EmaParams p = sim::EmaParams::datasheet();
    sim::SimResult ok;
    ok.samples.resize(20);
    for (std::size_t i = 0; i < ok.samples.size(); ++i) ok.samples[i].t_s = 5e-4 * static_cast<double>(i + 1);
    EXPECT_EQ(classify_simulation(ok, p), "");
    sim::SimResult nan = ok;
    nan.samples[4].current_a = std::nan("");
    EXPECT_EQ(classify_simulation(nan, p), "non_finite");
    sim::SimResult fast = ok;
    fast.samples[4].speed_rad_s = 2000;  // beyond the no-load speed V_dc / k_t = 1350 rad/s
    EXPECT_EQ(classify_simulation(fast, p), "non_physical");
    sim::SimResult cycle = ok;
    for (std::size_t i = 0; i < cycle.samples.size(); ++i) cycle.samples[i].speed_rad_s = i % 2 == 0 ? 300 : -300;
    EXPECT_EQ(classify_simulation(cycle, p), "limit_cycle");
}

TEST(DatasetTest, FileRoundTripKeepsEverySample) {
    DatasetSpec spec;
    spec.load_case = sim::LoadCase::A;
    spec.sequence = sim::Sequence::Brk;
    spec.count = 3;
    spec.seed = 2;
    const Dataset d = generate_dataset(spec, 2);
    const std::string path = temp_path("roundtrip.ds");
    write_dataset(path, d);
    const Dataset back = read_dataset(path);
    EXPECT_EQ(back.spec.load_case, sim::LoadCase::A);
    EXPECT_EQ(back.spec.sequence, sim::Sequence::Brk);
    EXPECT_EQ(back.spec.seed, 2u);
    EXPECT_EQ(back.filter.accepted, 3);
    ASSERT_EQ(back.runs.size(), 3u);
    EXPECT_EQ(back.runs[1].samples.size(), 1600u);  // BRK lasts 0.8 s
    for (std::size_t i = 0; i < 3; ++i) {
        EXPECT_EQ(back.runs[i].labels.eta_o, d.runs[i].labels.eta_o);
        EXPECT_EQ(back.runs[i].noise_seed, d.runs[i].noise_seed);
        for (std::size_t k = 0; k < d.runs[i].samples.size(); k += 97) {
            EXPECT_EQ(back.runs[i].samples[k].hinge_moment_nm, d.runs[i].samples[k].hinge_moment_nm);
            EXPECT_EQ(back.runs[i].samples[k].theta_m_rad, d.runs[i].samples[k].theta_m_rad);
        }
    }
    // Truncation is reported with the run index.
    {
        std::ifstream in(path, std::ios::binary);
        std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        std::ofstream out(path, std::ios::binary | std::ios::trunc);
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size() - 100));
    }
    EXPECT_THAT([&] { (void)read_dataset(path); }, ThrowsMessage<std::runtime_error>(HasSubstr("header announces 3 runs of 1600 samples (230979 bytes) but the file has 230879 bytes")));
    {
        std::ofstream out(path, std::ios::binary | std::ios::trunc);
        out << "not a dataset";
    }
    EXPECT_THAT([&] { (void)read_dataset(path); }, ThrowsMessage<std::runtime_error>(HasSubstr("magic EMADSET1 missing")));
    std::remove(path.c_str());
}

TEST(DatasetTest, SplitIsDeterministicForASeedAndAPartition) {
    const Split a = split_indices(500, 17);
    const Split b = split_indices(500, 17);
    const Split c = split_indices(500, 18);
    EXPECT_EQ(a.train, b.train);
    EXPECT_EQ(a.validation, b.validation);
    EXPECT_EQ(a.test, b.test);
    EXPECT_NE(a.train, c.train);
    EXPECT_EQ(a.train.size(), 375u);
    EXPECT_EQ(a.validation.size(), 75u);
    EXPECT_EQ(a.test.size(), 50u);
    std::set<int> all(a.train.begin(), a.train.end());
    all.insert(a.validation.begin(), a.validation.end());
    all.insert(a.test.begin(), a.test.end());
    EXPECT_EQ(all.size(), 500u);
    EXPECT_EQ(*all.begin(), 0);
    EXPECT_EQ(*all.rbegin(), 499);
    // Not the identity order.
    EXPECT_FALSE(std::is_sorted(a.train.begin(), a.train.end()));
}

TEST(DatasetTest, TooFewAcceptedRunsIsAnErrorWithCounts) {
    DatasetSpec spec;
    spec.count = 0;
    EXPECT_THAT([&] { (void)generate_dataset(spec, 1); },
                ThrowsMessage<std::runtime_error>(HasSubstr("dataset count 0 is outside [1, 16000] (kMaxDatasetCount)")));
    spec.count = kMaxDatasetCount + 1;  // before: kMaxSimulationsPerRun * count overflowed int ("only 0 of 0")
    EXPECT_THAT([&] { (void)generate_dataset(spec, 1); },
                ThrowsMessage<std::runtime_error>(HasSubstr("dataset count 16001 is outside [1, 16000]")));
}

}  // namespace
}  // namespace emadiag
