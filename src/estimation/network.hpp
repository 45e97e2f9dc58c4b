#pragma once
// The paper's network (section 2.8): one hidden layer of tansig neurons and a satlins output layer.
// Inputs are T_R (eq. 7) resampled to N timesteps by linear interpolation, optionally with speed and
// load, each normalised to [0, 1] by the training set's min/max. Targets are the health parameters
// normalised to [0, 1] (ema-reference.md section 8).
//
// satlins is MATLAB's symmetric saturating linear function, clamp(n, -1, 1). The network works
// internally on targets mapped to [-1, 1] (y = 2 u - 1, as MATLAB's mapminmax does), so the satlins
// clamp is exactly the paper's "predicted values outside [0, 1] are brought to the closest
// boundary". All MSE figures reported outside this class are in the [0, 1] space: mse01 = mse / 4.
#include "core/run.hpp"

#include <Eigen/Dense>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace emadiag {

/// MATLAB tansig: 2 / (1 + exp(-2 n)) - 1 (= tanh n).
[[nodiscard]] double tansig(double n);
/// MATLAB satlins: -1 below -1, n in [-1, 1], 1 above 1.
[[nodiscard]] double satlins(double n);

/// What a network reads and predicts.
struct NetworkSpec {
    sim::LoadCase load_case = sim::LoadCase::B;   ///< the model JSON's "case": "A", "A-ext", "B"
    sim::Sequence sequence = sim::Sequence::Dyn;  ///< the model JSON's "sequence": "dyn", "brk", "sweep"
    int timesteps = 500;              ///< N: T_R resampled to N points
    bool with_speed = false;          ///< also speed resampled to N points
    bool with_load = false;           ///< also F_R = H / tau resampled to N points
    /// "linear": the paper's linear interpolation at N points. "mean": the mean of the samples in
    /// each point's window (width span / (N - 1)), linear where a window holds no sample; an
    /// anti-aliasing refinement of ours for noisy runs.
    std::string resample = "linear";
    int hidden_neurons = 50;
    std::vector<std::string> outputs; ///< kParam* names, e.g. {FDJ_Nm, eta_O}

    [[nodiscard]] int input_count() const;
    [[nodiscard]] nlohmann::json to_json() const;
    static NetworkSpec from_json(const nlohmann::json& j, const std::string& where);
};

/// Resamples y(t) given at times t (strictly increasing) to n points evenly spaced from t.front() to
/// t.back(), by linear interpolation.
[[nodiscard]] std::vector<double> resample_linear(const std::vector<double>& t, const std::vector<double>& y, int n);

/// Window means of y(t) around n points evenly spaced from t.front() to t.back() (each window is
/// one point spacing wide, centred on its point); linear interpolation where a window is empty.
[[nodiscard]] std::vector<double> resample_mean(const std::vector<double>& t, const std::vector<double>& y, int n);

/// The raw (not normalised) input vector of a run for a spec: [T_R(N), speed(N)?, F_R(N)?].
/// Throws EmadiagError when the run has fewer than 2 samples.
[[nodiscard]] Eigen::VectorXd network_features(const Run& run, const NetworkSpec& spec);

/// Per-input min/max mapping to [0, 1] (the paper's normalisation). Constant inputs map to 0.
struct InputNormalisation {
    Eigen::VectorXd min;
    Eigen::VectorXd max;

    /// From a matrix with one run per column.
    static InputNormalisation fit(const Eigen::MatrixXd& x);
    [[nodiscard]] Eigen::MatrixXd apply(const Eigen::MatrixXd& x) const;
    [[nodiscard]] nlohmann::json to_json() const;
    static InputNormalisation from_json(const nlohmann::json& j, const std::string& where);
};

/// The activations of a network's last forward pass on one input matrix, kept by a caller that
/// evaluates the error at a point and then its gradient at the same point (SCG: Network::mse).
/// Valid only for the weights, inputs and kernel variant it was filled with (Network::mse checks).
struct MseCache {
    std::vector<double> weights;  ///< flatten() of the network that filled it
    std::vector<double> a1, z2;   ///< hidden (hidden x cols) and output (outputs x cols) activations
    const double* x = nullptr;    ///< the inputs' data (the same matrix, unchanged, for a hit)
    Eigen::Index cols = 0;
    std::string variant;
    bool valid = false;
    long hits = 0;  ///< forward passes saved
};

/// Two-layer feed-forward network, tansig hidden layer and satlins output, on columns of inputs.
class Network {
public:
    Network() = default;
    Network(int inputs, int hidden, int outputs);

    [[nodiscard]] int inputs() const { return static_cast<int>(w1_.cols()); }
    [[nodiscard]] int hidden() const { return static_cast<int>(w1_.rows()); }
    [[nodiscard]] int outputs() const { return static_cast<int>(w2_.rows()); }
    [[nodiscard]] int parameter_count() const;

    /// Nguyen-Widrow initialisation of the hidden layer (MATLAB initnw, inputs in [0, 1]) and
    /// uniform [-0.5, 0.5] / sqrt(hidden) for the output layer; seeded on std::mt19937_64.
    void initialise(std::uint64_t seed);

    /// All weights and biases as one vector: w1 (column-major), b1, w2 (column-major), b2.
    [[nodiscard]] Eigen::VectorXd flatten() const;
    void unflatten(const Eigen::VectorXd& x);

    /// Outputs in the internal [-1, 1] space for normalised inputs (one run per column).
    [[nodiscard]] Eigen::MatrixXd forward(const Eigen::MatrixXd& x) const;

    /// Mean squared error over all outputs and columns (internal space) against targets t, and,
    /// when grad is not null, its gradient with respect to flatten().
    /// With a cache: the forward pass is taken from it when it holds this network's weights and these
    /// inputs (x must not have changed since), else computed and stored in it. The same result bit
    /// for bit either way.
    [[nodiscard]] double mse(const Eigen::MatrixXd& x, const Eigen::MatrixXd& t, Eigen::VectorXd* grad = nullptr,
                             MseCache* cache = nullptr) const;

    [[nodiscard]] nlohmann::json to_json() const;
    static Network from_json(const nlohmann::json& j, const std::string& where);

private:
    Eigen::MatrixXd w1_;  ///< hidden x inputs
    Eigen::VectorXd b1_;
    Eigen::MatrixXd w2_;  ///< outputs x hidden
    Eigen::VectorXd b2_;
};

/// Maps [0, 1] targets to the internal [-1, 1] space and back.
[[nodiscard]] inline double to_internal(double u) { return 2.0 * u - 1.0; }
[[nodiscard]] inline double from_internal(double y) { return 0.5 * (y + 1.0); }

}  // namespace emadiag
