#pragma once
// A trained network of the paper (section 2.8) as shipped in models/*.json: the weights, the
// [0, 1] normalisation of inputs and outputs, the load case and sequence it was trained on, the
// number of timesteps, and the per-output standard error calibrated on held-out data.
// The estimator "network" of the HealthEstimate seam (ARCHITECTURE.md).
#include "core/run.hpp"
#include "estimation/health_estimate.hpp"
#include "estimation/network.hpp"
#include "emadiag/io/output_path.hpp"

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace emadiag {

/// Version of the model JSON schema written by NetworkModel::to_json.
inline constexpr int kNetworkModelVersion = 1;

class NetworkModel {
public:
    /// Reads a model JSON file; throws EmadiagError naming the file and the bad field.
    static NetworkModel load(const std::string& path);
    static NetworkModel from_json(const nlohmann::json& j, const std::string& where = "model");
    [[nodiscard]] nlohmann::json to_json() const;
    /// Written whole or not at all, never over one of `inputs` (emadiag/io/output_path.hpp).
    void save(const std::string& path, const io::OutputInputs& inputs = {}) const;

    /// Predicts the health parameters of a run (estimator "network"). Parameters the model does
    /// not predict are reported with identifiable = false and a note. eta_A follows from eta_O by
    /// eq. (4) when the model predicts eta_O. std_error is the calibrated per-output uncertainty.
    /// Throws EmadiagError when the run's case or sequence differs from the model's.
    [[nodiscard]] HealthEstimate estimate(const Run& run) const;

    /// Normalised [0, 1] outputs (section 8 of ema-reference.md) for a run.
    [[nodiscard]] std::vector<double> predict_normalised(const Run& run) const;

    NetworkSpec spec;                  ///< inputs, timesteps, outputs, case, sequence
    Network network;                   ///< weights (internal output space [-1, 1])
    InputNormalisation input_norm;     ///< per-input min/max to [0, 1]
    std::vector<double> std_error_normalised;  ///< per output, calibrated, in [0, 1] units
    nlohmann::json training;           ///< how it was trained (command, seed, counts, MSE, time)
};

}  // namespace emadiag
