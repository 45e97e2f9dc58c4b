// emadiag train: trains the paper's network (section 2.8) with SCG on a dataset and writes the model JSON.
#include "cli/command.hpp"
#include "cli/numeric_option.hpp"
#include "core/emadiag_error.hpp"
#include "emadiag/io/output_path.hpp"
#include "emadiag/io/text_field.hpp"
#include "estimation/health_estimate.hpp"
#include "estimation/nn_trainer.hpp"

#include <cstdio>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>
#include <thread>

namespace emadiag::cli {
namespace {

struct TrainCliOptions {
    std::string dataset;
    std::string out;
    int timesteps = 500;
    int runs = 0;
    int neurons = 50;
    std::string outputs;
    bool with_speed = false;
    bool with_load = false;
    std::uint64_t seed = 1;
    int max_epochs = 1000;
    int max_fail = 12;
    double goal = 1e-6;
    std::string resample = "linear";
};

/// The initial weights are seeded with seed + 1, which must not wrap.
constexpr std::uint64_t kMaxTrainSeed = std::numeric_limits<std::uint64_t>::max() - 1;

std::vector<std::string> default_outputs(sim::LoadCase load_case) {
    // The paper: case A predicts FDJ only (3.2); A-ext and B predict FDJ and eta_O (3.3, 3.4).
    if (load_case == sim::LoadCase::A) return {kParamFdj};
    return {kParamFdj, kParamEtaO};
}

std::vector<std::string> split_list(const std::string& s) {
    std::vector<std::string> out;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ',')) {
        if (!item.empty()) out.push_back(item);
    }
    return out;
}

const bool registered = register_command(Command{
    "train", "Train the paper's network (tansig/satlins, SCG) on a dataset and write the model JSON",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<TrainCliOptions>();
        sub.add_option("--dataset", o->dataset, "Dataset file from `emadiag dataset`")->required();
        sub.add_option("--out", o->out, "Model JSON to write")->required();
        sub.add_option("--timesteps", o->timesteps, "Timesteps N of the resampled T_R")->default_val(500)
            ->check(in_range(kMinTimesteps, kMaxTimesteps, "kMinTimesteps, kMaxTimesteps"));
        sub.add_option("--runs", o->runs, "Use the first N runs of the dataset (0: all)")->default_val(0)
            ->check(in_range(0, std::numeric_limits<int>::max()));
        sub.add_option("--neurons", o->neurons, "Hidden tansig neurons")->default_val(50)
            ->check(in_range(kMinHiddenNeurons, kMaxHiddenNeurons, "kMinHiddenNeurons, kMaxHiddenNeurons"));
        sub.add_option("--outputs", o->outputs, "Comma list of FDJ_Nm,FSJ_Nm,eta_O (default by case)");
        sub.add_flag("--with-speed", o->with_speed, "Also feed the resampled speed");
        sub.add_flag("--with-load", o->with_load, "Also feed the resampled load F_R = H / tau");
        sub.add_option("--seed", o->seed, "Seed of the split and of the initial weights")->default_val(1)
            ->check(in_range<std::uint64_t>(0, kMaxTrainSeed, "the initial weights take seed + 1"));
        sub.add_option("--max-epochs", o->max_epochs, "SCG epoch limit")->default_val(1000)
            ->check(in_range(kMinEpochs, kMaxEpochs, "kMinEpochs, kMaxEpochs"));
        sub.add_option("--max-fail", o->max_fail, "Validation failures before stopping")->default_val(12)
            ->check(in_range(kMinMaxFail, kMaxMaxFail, "kMinMaxFail, kMaxMaxFail"));
        sub.add_option("--resample", o->resample, "linear (the paper) or mean (window means, for noisy runs)")
            ->default_val("linear")
            ->check(CLI::IsMember({"linear", "mean"}));
        sub.add_option("--goal", o->goal, "Training MSE goal, normalised [0, 1] space (the paper: 1e-6)")->default_val(1e-6)
            ->check(in_range(0.0, kMaxGoal, "kMaxGoal"));
        return [o] {
            // Checked before training (minutes), not only when the model is written.
            io::check_output_path<EmadiagError>(o->out, "network model", io::OutputInputs({o->dataset}));
            const Dataset d = read_dataset(o->dataset);  // every sample finite, labels in range (dataset.hpp)
            TrainOptions t;
            t.spec.load_case = d.spec.load_case;
            t.spec.sequence = d.spec.sequence;
            t.spec.timesteps = o->timesteps;
            t.spec.hidden_neurons = o->neurons;
            t.spec.with_speed = o->with_speed;
            t.spec.with_load = o->with_load;
            t.spec.resample = o->resample;
            t.spec.outputs = o->outputs.empty() ? default_outputs(t.spec.load_case) : split_list(o->outputs);
            t.split_seed = o->seed;
            t.init_seed = o->seed + 1;
            t.scg.max_epochs = o->max_epochs;
            t.scg.max_fail = o->max_fail;
            t.scg.goal = o->goal;
            check_train_options(t);  // --outputs: known names, none twice, not eta_A
            const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
            const FeatureSet f = build_features(d, t.spec, o->runs, threads);
            TrainReport rep = train_network(f, t);
            rep.model.training["dataset"] = o->dataset;
            rep.model.training["dataset_seed"] = d.spec.seed;
            rep.model.training["noise"] = sim::to_string(d.spec.noise);
            rep.model.save(o->out, io::OutputInputs({o->dataset}));
            std::printf("trained %d-%d-%zu network on case %s, sequence %s, noise %s: %d runs (%zu/%zu/%zu)\n",
                        t.spec.input_count(), t.spec.hidden_neurons, t.spec.outputs.size(), sim::to_string(t.spec.load_case).c_str(),
                        sim::to_string(t.spec.sequence).c_str(), sim::to_string(d.spec.noise).c_str(), static_cast<int>(f.x.cols()),
                        rep.split.train.size(), rep.split.validation.size(), rep.split.test.size());
            std::printf("SCG: %d epochs, best epoch %d, stop: %s, %.2f s\n", rep.scg.epochs, rep.scg.best_epoch,
                        rep.scg.stop_reason.c_str(), rep.train_time_s);
            std::printf("normalised MSE: training %.4e, validation %.4e, test %.4e\n", rep.mse.train,
                        rep.mse.validation, rep.mse.test);
            for (std::size_t k = 0; k < t.spec.outputs.size(); ++k) {
                std::printf("  %-7s test MSE %.4e, calibrated std error %.4e (normalised)\n", t.spec.outputs[k].c_str(),
                            rep.mse.test_per_output[k], rep.model.std_error_normalised[k]);
            }
            std::printf("95 %% interval coverage on the test runs: %.1f %%\n", 100.0 * rep.test_coverage95);
            std::printf("wrote %s\n", io::escape_text(o->out).c_str());
            return 0;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
