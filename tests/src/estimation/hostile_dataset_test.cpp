// Hostile datasets and training options (issue 21 item 11): a dataset is checked as it is loaded
// (finite samples, increasing time, labels inside the datasheet's ranges, enough samples per run)
// with the file, the run index and the field in the message; an exception in a feature worker
// thread reaches the caller instead of ending the process; training options are checked against
// named bounds; a model holding a non-finite number is never produced.
#include "estimation/dataset.hpp"
#include "estimation/health_estimate.hpp"
#include "estimation/nn_trainer.hpp"

#include "core/emadiag_error.hpp"
#include "emadiag/sim/simulator.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>

namespace emadiag {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string temp_path(const std::string& name) { return std::string(EMADIAG_BINARY_DIR) + "/hostile_dataset_test_" + name; }

/// `runs` runs of `samples` samples with nominal labels and smooth, increasing signals.
Dataset small_dataset(int runs, std::size_t samples) {
    Dataset d;
    d.spec.load_case = sim::LoadCase::A;
    d.spec.count = runs;
    const sim::EmaParams p = sim::EmaParams::datasheet();
    d.constants = RunConstants{p.k_t_nm_per_a, p.j_kgm2, p.tau, sim::kSamplePeriodS};
    for (int r = 0; r < runs; ++r) {
        DatasetRun run;
        run.labels = HealthLabels{0.08, 0.12, 0.85, sim::eta_a_from_eta_o(0.85, p.tau)};
        run.noise_seed = static_cast<std::uint64_t>(r);
        for (std::size_t k = 0; k < samples; ++k) {
            const double t = static_cast<double>(k + 1) * sim::kSamplePeriodS;
            run.samples.push_back(sim::Sample{t, 1.0 + 0.01 * r + std::sin(100 * t), 10 * std::cos(50 * t), 0.1 * t, 2.0, 0.0});
        }
        d.runs.push_back(std::move(run));
    }
    return d;
}

/// Writes `d` after `edit` and reads it back; the message of read_dataset's refusal, or "".
std::string read_error(const std::string& name, Dataset d, const std::function<void(Dataset&)>& edit = {}) {
    if (edit) edit(d);
    const std::string path = temp_path(name);
    write_dataset(path, d);
    std::string message;
    try {
        (void)read_dataset(path);
    } catch (const EmadiagError& e) {
        message = e.what();
    }
    std::remove(path.c_str());
    return message;
}

TEST(HostileDataset, ASoundSmallDatasetIsRead) { EXPECT_EQ(read_error("sound.bin", small_dataset(3, 20)), ""); }

TEST(HostileDataset, InfiniteSampleIsRefusedNamingFileRunSampleAndField) {
    const std::string m = read_error("inf.bin", small_dataset(3, 20), [](Dataset& d) { d.runs[1].samples[3].current_a = kInf; });
    EXPECT_THAT(m, AllOf(HasSubstr("hostile_dataset_test_inf.bin: run 1: sample 3: current_A = inf is not finite")));
}

TEST(HostileDataset, NanLabelIsRefused) {
    const std::string m = read_error("nan_label.bin", small_dataset(3, 20), [](Dataset& d) { d.runs[2].labels.eta_o = kNaN; });
    EXPECT_THAT(m, HasSubstr("run 2: label eta_O = nan is outside the datasheet's range"));
}

TEST(HostileDataset, FdjOf100NmIsOutsideThePhysicalRange) {
    const std::string m = read_error("fdj100.bin", small_dataset(3, 20), [](Dataset& d) { d.runs[0].labels.fdj_nm = 100.0; });
    EXPECT_THAT(m, AllOf(HasSubstr("run 0: label FDJ_Nm = 100 is outside the datasheet's range [0.064"), HasSubstr("0.096")));
}

TEST(HostileDataset, TwoSamplesPerRunAreTooFew) {
    const std::string m = read_error("two.bin", small_dataset(12, 2));
    EXPECT_THAT(m, HasSubstr("samples_per_run 2 is below the limit kMinDatasetSamplesPerRun = 3"));
}

TEST(HostileDataset, TimeThatDoesNotIncreaseIsRefused) {
    const std::string m = read_error("time.bin", small_dataset(3, 20), [](Dataset& d) { d.runs[1].samples[5].t_s = d.runs[1].samples[4].t_s; });
    EXPECT_THAT(m, HasSubstr("run 1: sample 5: t_s = "));
    EXPECT_THAT(m, HasSubstr("does not increase"));
}

TEST(HostileDataset, NonPositiveConstantIsRefused) {
    const std::string m = read_error("tau.bin", small_dataset(3, 20), [](Dataset& d) { d.constants.tau = 0; });
    EXPECT_THAT(m, HasSubstr("header constant tau = 0 is not a finite number > 0"));
}

TEST(HostileDataset, AnExceptionInAFeatureWorkerReachesTheCaller) {
    // Built in memory (read_dataset would refuse it): run 5's time stands still, which eq. (7)'s
    // derivative refuses inside a worker thread. Before, that ended the process (std::terminate).
    Dataset d = small_dataset(12, 20);
    for (auto& s : d.runs[5].samples) s.t_s = 1.0;
    NetworkSpec spec;
    spec.load_case = sim::LoadCase::A;
    spec.timesteps = 10;
    spec.outputs = {kParamFdj};
    for (const unsigned threads : {1u, 2u, 4u}) {
        EXPECT_THAT([&] { (void)build_features(d, spec, 0, threads); },
                    ThrowsMessage<EmadiagError>(HasSubstr("network inputs of dataset run 5: time does not increase")))
            << threads << " threads";
    }
}

TrainOptions sound_options() {
    TrainOptions t;
    t.spec.load_case = sim::LoadCase::A;
    t.spec.timesteps = 10;
    t.spec.hidden_neurons = 2;
    t.spec.outputs = {kParamFdj};
    t.scg.max_epochs = 5;
    return t;
}

TEST(HostileDataset, TrainingOptionsAreCheckedAgainstNamedBounds) {
    EXPECT_NO_THROW(check_train_options(sound_options()));
    const auto refused = [](const std::function<void(TrainOptions&)>& edit, const std::string& message) {
        TrainOptions t = sound_options();
        edit(t);
        EXPECT_THAT([&] { check_train_options(t); }, ThrowsMessage<EmadiagError>(HasSubstr(message))) << message;
    };
    for (const int n : {0, 1, -1}) {
        refused([n](TrainOptions& t) { t.spec.timesteps = n; },
                "timesteps " + std::to_string(n) + " is outside [2, 10000] (kMinTimesteps, kMaxTimesteps)");
    }
    refused([](TrainOptions& t) { t.spec.hidden_neurons = -1; }, "hidden neurons -1 is outside [1, 1000]");
    refused([](TrainOptions& t) { t.spec.outputs = {kParamFdj, kParamFdj}; }, "outputs: FDJ_Nm is listed twice");
    refused([](TrainOptions& t) { t.spec.outputs = {kParamEtaA}; }, "predict eta_O; eta_A follows by eq. (4)");
    refused([](TrainOptions& t) { t.scg.goal = kNaN; }, "goal nan is not a number in [0, 1");
    refused([](TrainOptions& t) { t.scg.max_epochs = -3; }, "max epochs -3 is outside [1, 1000000]");
    refused([](TrainOptions& t) { t.scg.max_fail = 0; }, "max fail 0 is outside [1, 1000000]");
}

TEST(HostileDataset, AModelWithANonFiniteNumberIsNeverProduced) {
    // An infinite network input (a sample that slipped past the load checks) makes the input
    // normalisation infinite: training refuses to return that model instead of writing null.
    Dataset d = small_dataset(12, 20);
    const TrainOptions t = sound_options();
    FeatureSet f = build_features(d, t.spec, 0, 2);
    for (Eigen::Index i = 0; i < f.u.cols(); ++i) f.u(0, i) = 0.1 * static_cast<double>(i % 5);
    f.x(3, 7) = kInf;
    EXPECT_THAT([&] { (void)train_network(f, t); }, ThrowsMessage<EmadiagError>(HasSubstr("the trained model holds a non-finite number (")));
    NetworkModel m;
    m.std_error_normalised = {0.1, kNaN};
    EXPECT_EQ(non_finite_model_number(m), "std_error_normalised[1] = nan");
}

}  // namespace
}  // namespace emadiag
