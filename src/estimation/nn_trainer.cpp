#include "estimation/nn_trainer.hpp"

#include "core/emadiag_error.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <set>
#include <thread>

namespace emadiag {
namespace {

constexpr const char* kErrorPrefix = "[emadiag] ";
constexpr int kMinRunsForSplit = 10;  // at least one test run and one validation run

Eigen::MatrixXd columns(const Eigen::MatrixXd& m, const std::vector<int>& idx) {
    Eigen::MatrixXd out(m.rows(), static_cast<Eigen::Index>(idx.size()));
    for (std::size_t k = 0; k < idx.size(); ++k) out.col(static_cast<Eigen::Index>(k)) = m.col(idx[k]);
    return out;
}

Eigen::MatrixXd to_internal_space(const Eigen::MatrixXd& u) { return (2.0 * u.array() - 1.0).matrix(); }

void check_int(const char* name, int value, int lo, int hi, const char* lo_name, const char* hi_name) {
    if (value < lo || value > hi) {
        throw EmadiagError(std::string(name) + " " + std::to_string(value) + " is outside [" + std::to_string(lo) + ", " +
                           std::to_string(hi) + "] (" + lo_name + ", " + hi_name + ")");
    }
}

void check_spec(const NetworkSpec& spec) {
    check_int("timesteps", spec.timesteps, kMinTimesteps, kMaxTimesteps, "kMinTimesteps", "kMaxTimesteps");
    check_int("hidden neurons", spec.hidden_neurons, kMinHiddenNeurons, kMaxHiddenNeurons, "kMinHiddenNeurons",
              "kMaxHiddenNeurons");
    if (spec.resample != "linear" && spec.resample != "mean") {
        throw EmadiagError("resample '" + spec.resample + "' is not 'linear' or 'mean'");
    }
    if (spec.outputs.empty()) throw EmadiagError("outputs: the network needs at least one output");
    std::set<std::string> seen;
    for (const auto& name : spec.outputs) {
        if (name == kParamEtaA) throw EmadiagError("outputs: predict eta_O; eta_A follows by eq. (4)");
        (void)health_range(name);  // throws on an unknown name
        if (!seen.insert(name).second) throw EmadiagError("outputs: " + name + " is listed twice");
    }
}

template <class Dense>
void check_finite(std::string& first, const std::string& field, const Dense& m) {
    for (Eigen::Index i = 0; first.empty() && i < m.size(); ++i) {
        if (!std::isfinite(m.data()[i])) first = field + "[" + std::to_string(i) + "] = " + std::to_string(m.data()[i]);
    }
}

}  // namespace

void check_train_options(const TrainOptions& options) {
    check_spec(options.spec);
    check_int("max epochs", options.scg.max_epochs, kMinEpochs, kMaxEpochs, "kMinEpochs", "kMaxEpochs");
    check_int("max fail", options.scg.max_fail, kMinMaxFail, kMaxMaxFail, "kMinMaxFail", "kMaxMaxFail");
    if (!(options.scg.goal >= 0 && options.scg.goal <= kMaxGoal)) {
        throw EmadiagError("goal " + std::to_string(options.scg.goal) + " is not a number in [0, " + std::to_string(kMaxGoal) +
                           "] (kMaxGoal: the normalised MSE)");
    }
}

std::string non_finite_model_number(const NetworkModel& model) {
    std::string first;
    check_finite(first, "weights", model.network.flatten());
    check_finite(first, "input_norm.min", model.input_norm.min);
    check_finite(first, "input_norm.max", model.input_norm.max);
    for (std::size_t k = 0; first.empty() && k < model.std_error_normalised.size(); ++k) {
        const double v = model.std_error_normalised[k];
        if (!std::isfinite(v)) first = "std_error_normalised[" + std::to_string(k) + "] = " + std::to_string(v);
    }
    return first;
}

FeatureSet build_features(const Dataset& dataset, const NetworkSpec& spec, int runs, unsigned threads) {
    check_spec(spec);
    const int n = runs <= 0 ? static_cast<int>(dataset.runs.size()) : std::min(runs, static_cast<int>(dataset.runs.size()));
    if (runs > 0 && runs > static_cast<int>(dataset.runs.size())) {
        throw EmadiagError("asked for " + std::to_string(runs) + " runs, the dataset has " +
                           std::to_string(dataset.runs.size()));
    }
    std::vector<HealthRange> ranges;
    for (const auto& o : spec.outputs) ranges.push_back(health_range(o));
    FeatureSet f;
    f.x.resize(spec.input_count(), n);
    f.u.resize(static_cast<Eigen::Index>(spec.outputs.size()), n);
    // An exception in a worker is carried to the caller (std::exception_ptr) and rethrown after the
    // join, naming the run: thrown out of a thread it would end the process (std::terminate).
    std::vector<std::exception_ptr> failed(std::max(1u, threads));
    const auto work = [&](unsigned slot, int begin, int end) {
        int i = begin;
        try {
            for (; i < end; ++i) {
                f.x.col(i) = network_features(dataset.run(static_cast<std::size_t>(i)), spec);
                for (std::size_t o = 0; o < spec.outputs.size(); ++o) {
                    f.u(static_cast<Eigen::Index>(o), i) =
                        ranges[o].normalise(dataset.runs[static_cast<std::size_t>(i)].labels.get(spec.outputs[o]));
                }
            }
        } catch (const std::exception& e) {
            std::string what = e.what();
            if (what.rfind(kErrorPrefix, 0) == 0) what.erase(0, std::string(kErrorPrefix).size());
            failed[slot] = std::make_exception_ptr(EmadiagError("network inputs of dataset run " + std::to_string(i) + ": " + what));
        } catch (...) {
            failed[slot] = std::current_exception();
        }
    };
    threads = std::max(1u, threads);
    std::vector<std::thread> pool;
    const int per = (n + static_cast<int>(threads) - 1) / static_cast<int>(threads);
    for (unsigned t = 0; t < threads; ++t) {
        const int b = static_cast<int>(t) * per;
        const int e = std::min(n, b + per);
        if (b < e) pool.emplace_back(work, t, b, e);
    }
    for (auto& th : pool) th.join();
    for (const auto& e : failed) {
        if (e) std::rethrow_exception(e);  // the first failing block's (the lowest run index)
    }
    return f;
}

std::vector<double> calibrate_std_error(const Eigen::MatrixXd& residuals, double level) {
    std::vector<double> se(static_cast<std::size_t>(residuals.rows()), 0.0);
    const auto n = static_cast<std::size_t>(residuals.cols());
    if (n == 0) throw EmadiagError("calibration needs at least one held-out run");
    for (Eigen::Index r = 0; r < residuals.rows(); ++r) {
        std::vector<double> a(n);
        for (std::size_t k = 0; k < n; ++k) a[k] = std::abs(residuals(r, static_cast<Eigen::Index>(k)));
        std::sort(a.begin(), a.end());
        const auto rank = static_cast<std::size_t>(std::ceil(static_cast<double>(n + 1) * level));
        const double q = a[std::min(n, std::max<std::size_t>(rank, 1)) - 1];
        se[static_cast<std::size_t>(r)] = q / kZ95;
    }
    return se;
}

TrainReport train_network(const FeatureSet& features, const TrainOptions& options) {
    check_train_options(options);
    const auto n = static_cast<int>(features.x.cols());
    if (n < kMinRunsForSplit) {
        throw EmadiagError("training needs at least " + std::to_string(kMinRunsForSplit) + " runs, got " +
                           std::to_string(n));
    }
    if (features.x.rows() != options.spec.input_count() ||
        features.u.rows() != static_cast<Eigen::Index>(options.spec.outputs.size())) {
        throw EmadiagError("features do not match the network spec (inputs " + std::to_string(features.x.rows()) +
                           " vs " + std::to_string(options.spec.input_count()) + ")");
    }
    TrainReport rep;
    rep.split = split_indices(n, options.split_seed);
    if (rep.split.validation.empty() || rep.split.test.empty()) {
        throw EmadiagError("the split of " + std::to_string(n) + " runs leaves no validation or test run");
    }
    const auto start = std::chrono::steady_clock::now();
    const Eigen::MatrixXd x_train_raw = columns(features.x, rep.split.train);
    rep.model.input_norm = InputNormalisation::fit(x_train_raw);  // from the training runs only
    const Eigen::MatrixXd x_train = rep.model.input_norm.apply(x_train_raw);
    const Eigen::MatrixXd x_val = rep.model.input_norm.apply(columns(features.x, rep.split.validation));
    const Eigen::MatrixXd x_test = rep.model.input_norm.apply(columns(features.x, rep.split.test));
    const Eigen::MatrixXd t_train = to_internal_space(columns(features.u, rep.split.train));
    const Eigen::MatrixXd t_val = to_internal_space(columns(features.u, rep.split.validation));
    const Eigen::MatrixXd t_test = to_internal_space(columns(features.u, rep.split.test));

    rep.model.spec = options.spec;
    Network net(options.spec.input_count(), options.spec.hidden_neurons, static_cast<int>(options.spec.outputs.size()));
    net.initialise(options.init_seed);
    // MSE in [0, 1] space = internal MSE / 4 (u = (y + 1) / 2).
    constexpr double kToUnitSpace = 0.25;
    Network work = net;
    // SCG evaluates the error at a trial point and, when the step succeeds, its gradient at that same
    // point: the cache gives that second call the first one's forward pass (about a quarter of an
    // epoch's work), bit for bit.
    MseCache cache;
    const ScgObjective objective = [&](const Eigen::VectorXd& w, Eigen::VectorXd* grad) {
        work.unflatten(w);
        const double perf = work.mse(x_train, t_train, grad, &cache);
        if (grad != nullptr) *grad *= kToUnitSpace;
        return perf * kToUnitSpace;
    };
    Network vnet = net;
    const ScgValidation validation = [&](const Eigen::VectorXd& w) {
        vnet.unflatten(w);
        return vnet.mse(x_val, t_val) * kToUnitSpace;
    };
    rep.scg = train_scg(objective, net.flatten(), options.scg, validation);
    net.unflatten(rep.scg.x);
    rep.train_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    rep.model.network = net;

    rep.mse.train = net.mse(x_train, t_train) * kToUnitSpace;
    rep.mse.validation = net.mse(x_val, t_val) * kToUnitSpace;
    rep.mse.test = net.mse(x_test, t_test) * kToUnitSpace;
    const Eigen::MatrixXd y_val = net.forward(x_val);
    const Eigen::MatrixXd y_test = net.forward(x_test);
    rep.test_predicted = (0.5 * (y_test.array() + 1.0)).matrix();
    rep.test_target = (0.5 * (t_test.array() + 1.0)).matrix();
    const Eigen::MatrixXd val_res = (0.5 * (y_val - t_val).array()).matrix();
    rep.model.std_error_normalised = calibrate_std_error(val_res);
    int covered = 0;
    for (Eigen::Index o = 0; o < rep.test_predicted.rows(); ++o) {
        const double half = kZ95 * rep.model.std_error_normalised[static_cast<std::size_t>(o)];
        double sq = 0;
        for (Eigen::Index k = 0; k < rep.test_predicted.cols(); ++k) {
            const double e = rep.test_predicted(o, k) - rep.test_target(o, k);
            sq += e * e;
            if (std::abs(e) <= half) ++covered;
        }
        rep.mse.test_per_output.push_back(sq / static_cast<double>(rep.test_predicted.cols()));
    }
    rep.test_coverage95 = static_cast<double>(covered) / static_cast<double>(rep.test_predicted.size());
    if (const std::string bad = non_finite_model_number(rep.model); !bad.empty()) {
        throw EmadiagError("the trained model holds a non-finite number (" + bad +
                           "); no model is written (are the dataset's samples and labels finite?)");
    }
    rep.model.training = {{"runs", n},
                          {"split_seed", options.split_seed},
                          {"init_seed", options.init_seed},
                          {"train_runs", rep.split.train.size()},
                          {"validation_runs", rep.split.validation.size()},
                          {"test_runs", rep.split.test.size()},
                          {"epochs", rep.scg.epochs},
                          {"best_epoch", rep.scg.best_epoch},
                          {"stop_reason", rep.scg.stop_reason},
                          {"mse_train", rep.mse.train},
                          {"mse_validation", rep.mse.validation},
                          {"mse_test", rep.mse.test},
                          {"mse_test_per_output", rep.mse.test_per_output},
                          {"test_coverage95", rep.test_coverage95},
                          {"train_time_s", rep.train_time_s},
                          {"uncertainty", "std_error = 95 % split-conformal quantile of |residual| on the validation runs / 1.96"}};
    return rep;
}

}  // namespace emadiag
