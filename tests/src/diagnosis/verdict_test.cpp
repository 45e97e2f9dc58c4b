// The verdict rules (diagnosis/verdict.hpp) on hand-made estimates, and the limits file.
#include "core/emadiag_error.hpp"
#include "diagnosis/health_limits.hpp"
#include "diagnosis/verdict.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

using namespace emadiag;
using ::testing::HasSubstr;

namespace {

ParameterEstimate value(const char* name, double v, double se) { return {name, v, se, true, "test", ""}; }
ParameterEstimate unidentifiable(const char* name) { return {name, std::nullopt, 0, false, "test", "not identifiable: eta confound"}; }

AssessedRun run(const std::string& seq, std::vector<ParameterEstimate> physics, std::vector<ParameterEstimate> network = {}) {
    AssessedRun r;
    r.sequence = sim::parse_sequence(seq);
    r.valid = true;
    RunEstimates e;
    e.estimates.push_back({EstimatorMethod::Physics, std::move(physics), {}});
    if (!network.empty()) e.estimates.push_back({EstimatorMethod::Network, std::move(network), {}});
    r.estimates = e;
    return r;
}

const HealthLimits kLimits = HealthLimits::datasheet_envelope();

}  // namespace

TEST(HealthLimits, DatasheetEnvelopeIsSection8) {
    ASSERT_NE(kLimits.find(kParamFdj), nullptr);
    EXPECT_EQ(kLimits.find(kParamFdj)->kind, LimitKind::Max);
    EXPECT_DOUBLE_EQ(kLimits.find(kParamFdj)->limit, 0.096);
    EXPECT_DOUBLE_EQ(kLimits.find(kParamFsj)->limit, 0.144);
    EXPECT_EQ(kLimits.find(kParamEtaA)->kind, LimitKind::Min);
    EXPECT_NEAR(kLimits.find(kParamEtaA)->limit, 0.659031, 1e-6);  // 0.8 x 0.823788, as the sheet rounds it
    EXPECT_EQ(kLimits.find(kParamEtaO)->kind, LimitKind::Min);
    EXPECT_GT(kLimits.find(kParamEtaO)->limit, 0.5);
    EXPECT_LT(kLimits.find(kParamEtaO)->limit, 0.9);
}

TEST(HealthLimits, FileOverridesSomeAndKeepsTheRest) {
    const HealthLimits h = HealthLimits::from_json(nlohmann::json::parse(R"({"FSJ_Nm": {"max": 0.15}, "eta_A": {"min": 0.7}})"), "x.json");
    EXPECT_DOUBLE_EQ(h.find(kParamFsj)->limit, 0.15);
    EXPECT_DOUBLE_EQ(h.find(kParamEtaA)->limit, 0.7);
    EXPECT_DOUBLE_EQ(h.find(kParamFdj)->limit, 0.096);
    EXPECT_EQ(h.source, "x.json");
    EXPECT_EQ(HealthLimits::from_json(h.to_json(), "y").to_json(), h.to_json());
}

TEST(HealthLimits, EveryProblemInAFileIsNamed) {
    const auto bad = nlohmann::json::parse(R"({"FDJ_Nm": {"min": 0.05}, "FSJ": {"max": 1}, "eta_O": {"min": -1}, "eta_A": 0.7})");
    try {
        (void)HealthLimits::from_json(bad, "lim.json");
        FAIL() << "no error";
    } catch (const EmadiagError& e) {
        const std::string m = e.what();
        EXPECT_THAT(m, HasSubstr("lim.json: 4 problem(s)"));
        EXPECT_THAT(m, HasSubstr("FDJ_Nm: expected {\"max\": value} (a min limit makes no sense for it)"));
        EXPECT_THAT(m, HasSubstr("unknown parameter \"FSJ\""));
        EXPECT_THAT(m, HasSubstr("eta_O.min: -1 is not a finite positive number"));
        EXPECT_THAT(m, HasSubstr("eta_A: expected {\"min\": value}, got 0.7"));
    }
    const std::string path = std::string(EMADIAG_BINARY_DIR) + "/verdict_test_limits.json";
    { std::ofstream(path) << "{ not json"; }
    EXPECT_THAT([&] { (void)HealthLimits::load(path); }, ::testing::ThrowsMessage<EmadiagError>(HasSubstr(path + ": not valid JSON")));
    std::remove(path.c_str());
    EXPECT_THAT([&] { (void)HealthLimits::load(path); }, ::testing::ThrowsMessage<EmadiagError>(HasSubstr(path + ": cannot open")));
}

TEST(Verdict, ClassifyUsesTheWhole95PercentInterval) {
    const ParameterLimit max{kParamFsj, LimitKind::Max, 0.144};
    const double se = 0.001, half = kZ95 * se;
    EXPECT_EQ(classify(0.144 - half, se, max), FindingStatus::Within);  // upper end exactly on the limit
    EXPECT_EQ(classify(0.144 - half + 1e-6, se, max), FindingStatus::Straddles);
    EXPECT_EQ(classify(0.144, se, max), FindingStatus::Straddles);
    EXPECT_EQ(classify(0.144 + half + 1e-6, se, max), FindingStatus::Beyond);
    const ParameterLimit min{kParamEtaA, LimitKind::Min, 0.66};
    EXPECT_EQ(classify(0.66 + half, se, min), FindingStatus::Within);
    EXPECT_EQ(classify(0.66, se, min), FindingStatus::Straddles);
    EXPECT_EQ(classify(0.66 - half - 1e-6, se, min), FindingStatus::Beyond);
}

TEST(Verdict, HealthyFrictionWithEtaNotIdentifiableIsServiceable) {
    const auto a = assess({run("dyn", {value(kParamFdj, 0.08, 0.001), unidentifiable(kParamEtaO), unidentifiable(kParamEtaA)}),
                           run("brk", {value(kParamFdj, 0.081, 0.0005), value(kParamFsj, 0.12, 0.002)})},
                          kLimits);
    EXPECT_EQ(a.verdict, Verdict::Serviceable) << a.reason;
    ASSERT_EQ(a.findings.size(), 5u);
    EXPECT_EQ(to_string(a.findings[0].estimator), "physics:dyn");
    EXPECT_EQ(a.findings[1].status, FindingStatus::NotIdentifiable);
    EXPECT_EQ(to_string(a.findings[4].estimator), "physics:brk");
    EXPECT_EQ(a.findings[4].status, FindingStatus::Within);
}

TEST(Verdict, PhysicsBeyondIsUnserviceableAndNamesTheParameter) {
    const auto a = assess({run("brk", {value(kParamFdj, 0.08, 0.001), value(kParamFsj, 0.17, 0.002)})}, kLimits);
    EXPECT_EQ(a.verdict, Verdict::Unserviceable);
    EXPECT_THAT(a.reason, HasSubstr("FSJ_Nm 0.17"));
    EXPECT_THAT(a.reason, HasSubstr("max 0.144 (physics:brk)"));
}

TEST(Verdict, StraddlingIsInconclusiveAndAskedToRetest) {
    const auto a = assess({run("brk", {value(kParamFdj, 0.08, 0.001), value(kParamFsj, 0.143, 0.002)})}, kLimits);
    EXPECT_EQ(a.verdict, Verdict::Inconclusive);
    EXPECT_THAT(a.reason, HasSubstr("straddles the limit; repeat the test"));
}

TEST(Verdict, NetworkBeyondWherePhysicsIsWithinIsADisagreement) {
    const auto a = assess({run("dyn", {value(kParamFdj, 0.08, 0.001)}, {value(kParamFdj, 0.11, 0.001)})}, kLimits);
    EXPECT_EQ(a.verdict, Verdict::Inconclusive);
    EXPECT_THAT(a.reason, HasSubstr("the methods disagree"));
    EXPECT_THAT(a.reason, HasSubstr("network:dyn"));
    // The network agreeing changes nothing.
    EXPECT_EQ(assess({run("dyn", {value(kParamFdj, 0.08, 0.001)}, {value(kParamFdj, 0.0805, 0.001)})}, kLimits).verdict,
              Verdict::Serviceable);
}

TEST(Verdict, InvalidRunIsNoTestWhateverTheEstimatesSay) {
    auto bad = run("dyn", {value(kParamFdj, 0.2, 0.001)});
    bad.valid = false;
    bad.invalid_reason = "telemetry loss 2.1 % above the 1 % limit";
    const auto a = assess({run("brk", {value(kParamFsj, 0.12, 0.001)}), bad}, kLimits);
    EXPECT_EQ(a.verdict, Verdict::NoTest);
    EXPECT_THAT(a.reason, HasSubstr("the dyn run is not valid (telemetry loss 2.1 %"));
    EXPECT_EQ(assess({}, kLimits).verdict, Verdict::NoTest);
}

TEST(Verdict, NothingMeasuredIsInconclusive) {
    const auto a = assess({run("dyn", {unidentifiable(kParamEtaO), unidentifiable(kParamEtaA)})}, kLimits);
    EXPECT_EQ(a.verdict, Verdict::Inconclusive);
    EXPECT_THAT(a.reason, HasSubstr("no parameter could be measured"));
}
