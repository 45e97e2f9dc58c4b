// Issue 21 item 3: a network model file is checked at load; each problem names the field and value
// (a negative or enormous std_error printed "+/- -0.016, 95 % [0.111, 0.049] ... agree" before).
#include "core/emadiag_error.hpp"
#include "estimation/network_model.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>

using namespace emadiag;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

namespace {

const nlohmann::json& shipped() {
    static const nlohmann::json j = [] {
        std::ifstream in(std::string(EMADIAG_SOURCE_DIR) + "/models/case_b.json");
        return nlohmann::json::parse(in);
    }();
    return j;
}

}  // namespace

TEST(HostileNetworkModel, EveryShippedModelLoads) {
    for (const char* name : {"case_a", "case_a_ext", "case_b", "case_a_typical", "case_a_ext_typical", "case_b_typical"})
        EXPECT_NO_THROW((void)NetworkModel::load(std::string(EMADIAG_SOURCE_DIR) + "/models/" + name + ".json")) << name;
}

TEST(HostileNetworkModel, NonsenseFieldsAreRefusedNamingFieldAndValue) {
    const struct {
        const char* what;
        void (*edit)(nlohmann::json&);
        const char* message;
    } cases[] = {
        {"negative se", [](nlohmann::json& m) { m["std_error_normalised"][0] = -0.016; }, "std_error_normalised[0] (FDJ_Nm) = -0.016 is not in (0, 1]"},
        {"zero se", [](nlohmann::json& m) { m["std_error_normalised"][1] = 0.0; }, "std_error_normalised[1] (eta_O) = 0 is not in (0, 1]"},
        {"huge se", [](nlohmann::json& m) { m["std_error_normalised"][0] = 1e308; }, "std_error_normalised[0] (FDJ_Nm) = 1e+308"},
        {"hidden transfer", [](nlohmann::json& m) { m["network"]["hidden_transfer"] = "bogus"; }, "network.hidden_transfer is \"bogus\", expected \"tansig\""},
        {"output transfer", [](nlohmann::json& m) { m["network"]["output_transfer"] = 3; }, "network.output_transfer is 3, expected \"satlins\""},
        {"max = min", [](nlohmann::json& m) { m["input_normalisation"]["max"][7] = m["input_normalisation"]["min"][7]; }, "input_normalisation: input 7 has min"},
        {"max < min", [](nlohmann::json& m) { m["input_normalisation"]["max"][0] = -1e9; }, "input_normalisation: input 0 has min"},
        {"duplicate outputs", [](nlohmann::json& m) { m["spec"]["outputs"][1] = "FDJ_Nm"; }, "spec.outputs[1] \"FDJ_Nm\" repeats spec.outputs[0]"},
    };
    EXPECT_NO_THROW((void)NetworkModel::from_json(shipped(), "m.json"));
    for (const auto& c : cases) {
        nlohmann::json m = shipped();
        c.edit(m);
        EXPECT_THAT([&] { (void)NetworkModel::from_json(m, "m.json"); },
                    ThrowsMessage<EmadiagError>(AllOf(HasSubstr("m.json: 1 problem(s) in the network model"), HasSubstr(c.message))))
            << c.what;
    }
}
