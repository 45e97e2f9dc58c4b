// Issue 21 item 3: JSON that parses but means nothing. A key repeated in one object (nlohmann keeps
// the last silently) is refused by every loader (io::parse_bounded_json); limits that no actuator
// can have (an efficiency above 1, a friction torque above T_max) are refused naming key and value.
#include "core/emadiag_error.hpp"
#include "diagnosis/health_limits.hpp"
#include "emadiag/io/bounded_json.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

using namespace emadiag;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

TEST(HostileJsonSemantics, ARepeatedKeyIsRefusedWithItsObjectsPath) {
    std::string error;
    EXPECT_FALSE(io::parse_bounded_json(R"({"eta_O": {"min": 0.8}, "eta_O": {"min": 0.1}})", error));
    EXPECT_THAT(error, HasSubstr("duplicate key \"eta_O\" in the object at /"));
    error.clear();
    EXPECT_FALSE(io::parse_bounded_json(R"({"network": {"layers": [{"w": 1, "w": 2}]}})", error));
    EXPECT_THAT(error, HasSubstr("duplicate key \"w\" in the object at /network/layers/*"));
    // The same key in different objects, and in objects side by side, is fine.
    error.clear();
    const auto j = io::parse_bounded_json(R"({"a": {"max": 1}, "b": {"max": 2}, "c": [{"k": 1}, {"k": 2}]})", error);
    ASSERT_TRUE(j) << error;
    EXPECT_EQ(j->at("c").at(1).at("k"), 2);
}

TEST(HostileJsonSemantics, LimitsNoActuatorCanHaveAreRefused) {
    const struct { const char* json; const char* message; } cases[] = {
        {R"({"eta_O": {"min": 5}})", "eta_O.min: 5 exceeds the largest possible efficiency"},
        {R"({"eta_A": {"min": 1.0000001}})", "eta_A.min: 1.0000001 exceeds the largest possible efficiency"},
        {R"({"FSJ_Nm": {"max": 4.5}})", "FSJ_Nm.max: 4.5 N m exceeds the motor torque saturation T_max"},
        {R"({"FDJ_Nm": {"max": -0.1}})", "FDJ_Nm.max: -0.1 is not a finite positive number"},
    };
    for (const auto& c : cases) {
        std::string error;
        const auto j = io::parse_bounded_json(c.json, error);
        ASSERT_TRUE(j) << error;
        EXPECT_THAT([&] { (void)HealthLimits::from_json(*j, "l.json"); }, ThrowsMessage<EmadiagError>(HasSubstr(c.message))) << c.json;
    }
    // The edges are limits: an efficiency of exactly 1 and a friction of exactly T_max.
    std::string error;
    const auto edge = io::parse_bounded_json(R"({"eta_O": {"min": 1}, "FDJ_Nm": {"max": 4}})", error);
    ASSERT_TRUE(edge) << error;
    const HealthLimits limits = HealthLimits::from_json(*edge, "l.json");
    EXPECT_EQ(limits.find("eta_O")->limit, 1.0);
    EXPECT_EQ(limits.find("FDJ_Nm")->limit, 4.0);
}
