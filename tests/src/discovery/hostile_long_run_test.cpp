// A long run (issue 21 item 12): discovery's work is bounded by analysing the run's first
// kMaxAnalysedSamples samples, and the report states what was analysed. Tested with a small window
// (DiscoveryOptions::max_samples) on a 0.75 s DYN run, so the test runs one short discovery; the
// 2-million-row figures are in docs/discovery.md.
#include "core/sim_run.hpp"
#include "discovery/discovery.hpp"
#include "discovery/many_run/multi_run.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace {

using ::testing::HasSubstr;
namespace dsc = emadiag::discovery;

emadiag::Run run_of(double duration_s) {
    emadiag::sim::SimConfig c;
    c.load_case = emadiag::sim::LoadCase::B;
    c.sequence = emadiag::sim::Sequence::Dyn;
    c.noise = emadiag::sim::NoiseProfile::Typical;
    c.seed = 7;
    c.duration_s = duration_s;
    c.params.effects.set("viscous", 2e-4);
    return emadiag::make_run(c, emadiag::sim::simulate(c));
}

TEST(HostileLongRun, TheWindowIsTheRunsStartWithItsMetadata) {
    emadiag::Run r = run_of(0.75);
    ASSERT_EQ(r.samples.size(), 1500u);
    r.extra_columns.emplace_back("extra", std::vector<double>(r.samples.size(), 1.5));
    const emadiag::Run w = dsc::analysis_window(r, 1000);
    ASSERT_EQ(w.samples.size(), 1000u);
    EXPECT_EQ(w.samples.back().t_s, r.samples[999].t_s);
    EXPECT_EQ(w.meta, r.meta);
    EXPECT_EQ(w.load_case, r.load_case);
    ASSERT_EQ(w.extra_columns.size(), 1u);
    EXPECT_EQ(w.extra_columns[0].second.size(), 1000u);
    EXPECT_EQ(dsc::analysis_window(r, 5000).samples.size(), 1500u);  // a short run is whole
}

TEST(HostileLongRun, ALongRunIsAnalysedOnAWindowAndTheReportSaysSo) {
    const emadiag::Run r = run_of(0.75);
    dsc::DiscoveryOptions opt;
    opt.max_samples = 1000;
    const dsc::DiscoveryReport long_run = dsc::discover(r, opt);
    EXPECT_EQ(long_run.samples, 1000u);
    EXPECT_EQ(long_run.total_samples, 1500u);
    EXPECT_THAT(long_run.analysis_text(), HasSubstr("analysed 1000 of 1500 samples in 1 window (the run's first 1000 samples"));
    EXPECT_THAT(long_run.to_json().dump(), HasSubstr("\"total_samples\":1500"));
    EXPECT_THAT(long_run.notes, ::testing::Contains(long_run.analysis_text()));
    // The same findings as the window analysed on its own.
    const dsc::DiscoveryReport window = dsc::discover(dsc::analysis_window(r, 1000), opt);
    EXPECT_EQ(long_run.added_effects(), window.added_effects());
    EXPECT_EQ(long_run.summary(), window.summary());
    EXPECT_EQ(window.analysis_text(), "");  // a run within the bound says nothing
}

}  // namespace
