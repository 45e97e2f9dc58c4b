#include "estimation/eigen_dense.hpp"  // first: Eigen with its AVX-512 false positive scoped (see there)
#include "estimation/network.hpp"

#include "core/emadiag_error.hpp"
#include "core/residual_torque.hpp"
#include "emadiag/sim/sim_error.hpp"
#include "estimation/dataset.hpp"
#include "estimation/network_kernels.hpp"

#include <algorithm>
#include <cmath>
#include <random>

namespace emadiag {
namespace {

constexpr double kNguyenWidrowGain = 0.7;  // MATLAB initnw

std::vector<double> to_vector(const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); }

Eigen::VectorXd vector_from_json(const nlohmann::json& j, const std::string& where, Eigen::Index expected) {
    const auto v = j.get<std::vector<double>>();
    if (expected >= 0 && static_cast<Eigen::Index>(v.size()) != expected) {
        throw EmadiagError(where + " has " + std::to_string(v.size()) + " values, expected " + std::to_string(expected));
    }
    return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

Eigen::MatrixXd matrix_from_json(const nlohmann::json& j, const std::string& where, Eigen::Index rows, Eigen::Index cols) {
    const Eigen::VectorXd flat = vector_from_json(j, where, rows * cols);
    return Eigen::Map<const Eigen::MatrixXd>(flat.data(), rows, cols);
}

}  // namespace

double tansig(double n) { return std::tanh(n); }
double satlins(double n) { return std::clamp(n, -1.0, 1.0); }

int NetworkSpec::input_count() const { return timesteps * (1 + (with_speed ? 1 : 0) + (with_load ? 1 : 0)); }

nlohmann::json NetworkSpec::to_json() const {
    return {{"case", sim::to_string(load_case)}, {"sequence", sim::to_string(sequence)}, {"timesteps", timesteps},
            {"with_speed", with_speed},  {"with_load", with_load}, {"hidden_neurons", hidden_neurons},
            {"outputs", outputs},        {"resample", resample}};
}

NetworkSpec NetworkSpec::from_json(const nlohmann::json& j, const std::string& where) {
    NetworkSpec s;
    try {
        // The one parser of each, at the edge (the model JSON).
        s.load_case = sim::parse_load_case(j.at("case").get<std::string>());
        s.sequence = sim::parse_sequence(j.at("sequence").get<std::string>());
        s.timesteps = j.at("timesteps").get<int>();
        s.with_speed = j.at("with_speed").get<bool>();
        s.with_load = j.at("with_load").get<bool>();
        s.hidden_neurons = j.at("hidden_neurons").get<int>();
        s.outputs = j.at("outputs").get<std::vector<std::string>>();
        s.resample = j.value("resample", std::string("linear"));
    } catch (const nlohmann::json::exception& e) {
        throw EmadiagError(where + ": " + e.what());
    } catch (const sim::SimError& e) {
        throw EmadiagError(where + ": " + e.what());
    }
    constexpr int kMinTimesteps = 2;
    if (s.timesteps < kMinTimesteps) {
        throw EmadiagError(where + ": timesteps " + std::to_string(s.timesteps) + " is below " +
                           std::to_string(kMinTimesteps));
    }
    if (s.hidden_neurons < 1) {
        throw EmadiagError(where + ": hidden_neurons " + std::to_string(s.hidden_neurons) + " is below 1");
    }
    if (s.outputs.empty()) throw EmadiagError(where + ": outputs is empty");
    if (s.resample != "linear" && s.resample != "mean") {
        throw EmadiagError(where + ": resample '" + s.resample + "' is not 'linear' or 'mean'");
    }
    for (const auto& o : s.outputs) (void)health_range(o);  // throws on an unknown name
    return s;
}

std::vector<double> resample_linear(const std::vector<double>& t, const std::vector<double>& y, int n) {
    if (t.size() != y.size() || t.size() < 2) {
        throw EmadiagError("resample_linear needs at least 2 points with matching sizes, got t " +
                           std::to_string(t.size()) + " and y " + std::to_string(y.size()));
    }
    if (n < 2) throw EmadiagError("resample_linear: n " + std::to_string(n) + " is below 2");
    std::vector<double> out(static_cast<std::size_t>(n));
    const double t0 = t.front();
    const double t1 = t.back();
    std::size_t k = 0;
    for (int i = 0; i < n; ++i) {
        const double ti = i == n - 1 ? t1 : t0 + (t1 - t0) * static_cast<double>(i) / static_cast<double>(n - 1);
        while (k + 2 < t.size() && t[k + 1] < ti) ++k;
        const double dt = t[k + 1] - t[k];
        const double w = dt > 0 ? std::clamp((ti - t[k]) / dt, 0.0, 1.0) : 0.0;
        out[static_cast<std::size_t>(i)] = y[k] + w * (y[k + 1] - y[k]);
    }
    return out;
}

std::vector<double> resample_mean(const std::vector<double>& t, const std::vector<double>& y, int n) {
    std::vector<double> out = resample_linear(t, y, n);  // also checks the sizes
    const double t0 = t.front();
    const double h = (t.back() - t0) / static_cast<double>(n - 1);
    std::size_t k = 0;
    for (int i = 0; i < n; ++i) {
        const double lo = t0 + h * (static_cast<double>(i) - 0.5);
        const double hi = lo + h;
        while (k < t.size() && t[k] < lo) ++k;
        double sum = 0;
        int count = 0;
        for (std::size_t j = k; j < t.size() && t[j] < hi; ++j) {
            sum += y[j];
            ++count;
        }
        if (count > 0) out[static_cast<std::size_t>(i)] = sum / count;
    }
    return out;
}

Eigen::VectorXd network_features(const Run& run, const NetworkSpec& spec) {
    if (run.samples.size() < 2) {
        throw EmadiagError("network inputs need at least 2 samples, the run has " + std::to_string(run.samples.size()));
    }
    const std::size_t m = run.samples.size();
    std::vector<double> t(m), speed(m), load(m);
    for (std::size_t i = 0; i < m; ++i) {
        t[i] = run.samples[i].t_s;
        speed[i] = run.samples[i].speed_rad_s;
        load[i] = run.samples[i].hinge_moment_nm / run.constants.tau;  // F_R = H / tau (section 2)
    }
    Eigen::VectorXd x(spec.input_count());
    Eigen::Index at = 0;
    const auto put = [&](const std::vector<double>& y) {
        const auto r = spec.resample == "mean" ? resample_mean(t, y, spec.timesteps) : resample_linear(t, y, spec.timesteps);
        for (double v : r) x(at++) = v;
    };
    put(residual_torque_nm(run));  // eq. (7)
    if (spec.with_speed) put(speed);
    if (spec.with_load) put(load);
    return x;
}

InputNormalisation InputNormalisation::fit(const Eigen::MatrixXd& x) {
    return InputNormalisation{x.rowwise().minCoeff(), x.rowwise().maxCoeff()};
}

Eigen::MatrixXd InputNormalisation::apply(const Eigen::MatrixXd& x) const {
    if (x.rows() != min.size()) {
        throw EmadiagError("input has " + std::to_string(x.rows()) + " rows, the normalisation " +
                           std::to_string(min.size()));
    }
    Eigen::MatrixXd out(x.rows(), x.cols());
    for (Eigen::Index r = 0; r < x.rows(); ++r) {
        const double span = max(r) - min(r);
        if (span > 0) {
            out.row(r) = (x.row(r).array() - min(r)) / span;
        } else {
            out.row(r).setZero();
        }
    }
    return out;
}

nlohmann::json InputNormalisation::to_json() const { return {{"min", to_vector(min)}, {"max", to_vector(max)}}; }

InputNormalisation InputNormalisation::from_json(const nlohmann::json& j, const std::string& where) {
    try {
        InputNormalisation n;
        n.min = vector_from_json(j.at("min"), where + ".min", -1);
        n.max = vector_from_json(j.at("max"), where + ".max", n.min.size());
        return n;
    } catch (const nlohmann::json::exception& e) {
        throw EmadiagError(where + ": " + e.what());
    }
}

Network::Network(int inputs, int hidden, int outputs)
    : w1_(Eigen::MatrixXd::Zero(hidden, inputs)),
      b1_(Eigen::VectorXd::Zero(hidden)),
      w2_(Eigen::MatrixXd::Zero(outputs, hidden)),
      b2_(Eigen::VectorXd::Zero(outputs)) {
    if (inputs < 1 || hidden < 1 || outputs < 1) {
        throw EmadiagError("network sizes must be positive: inputs " + std::to_string(inputs) + ", hidden " +
                           std::to_string(hidden) + ", outputs " + std::to_string(outputs));
    }
}

int Network::parameter_count() const {
    return static_cast<int>(w1_.size() + b1_.size() + w2_.size() + b2_.size());
}

void Network::initialise(std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    const auto rands = [&rng] { return 2.0 * uniform01(rng()) - 1.0; };
    const int s = hidden();
    const int r = inputs();
    // MATLAB initnw (Nguyen-Widrow) for a tansig layer: random unit directions of magnitude
    // 0.7 S^(1/R), biases spread over [-mag, mag]; then mapped from the [-1, 1] input range of the
    // rule to our [0, 1] inputs (x' = 2 x - 1).
    const double magnitude = kNguyenWidrowGain * std::pow(static_cast<double>(s), 1.0 / static_cast<double>(r));
    for (int i = 0; i < s; ++i) {
        for (int k = 0; k < r; ++k) w1_(i, k) = rands();
        const double norm = w1_.row(i).norm();
        if (norm > 0) w1_.row(i) *= magnitude / norm;
        const double spread = s == 1 ? 0.0 : -1.0 + 2.0 * static_cast<double>(i) / static_cast<double>(s - 1);
        b1_(i) = magnitude * spread * (w1_(i, 0) >= 0 ? 1.0 : -1.0);
        b1_(i) -= w1_.row(i).sum();
        w1_.row(i) *= 2.0;
    }
    const double out_scale = 0.5 / std::sqrt(static_cast<double>(s));
    for (int i = 0; i < outputs(); ++i) {
        for (int k = 0; k < s; ++k) w2_(i, k) = out_scale * rands();
        b2_(i) = out_scale * rands();
    }
}

Eigen::VectorXd Network::flatten() const {
    Eigen::VectorXd x(parameter_count());
    Eigen::Index at = 0;
    x.segment(at, w1_.size()) = Eigen::Map<const Eigen::VectorXd>(w1_.data(), w1_.size());
    at += w1_.size();
    x.segment(at, b1_.size()) = b1_;
    at += b1_.size();
    x.segment(at, w2_.size()) = Eigen::Map<const Eigen::VectorXd>(w2_.data(), w2_.size());
    at += w2_.size();
    x.segment(at, b2_.size()) = b2_;
    return x;
}

void Network::unflatten(const Eigen::VectorXd& x) {
    if (x.size() != parameter_count()) {
        throw EmadiagError("weight vector has " + std::to_string(x.size()) + " values, the network " +
                           std::to_string(parameter_count()));
    }
    Eigen::Index at = 0;
    Eigen::Map<Eigen::VectorXd>(w1_.data(), w1_.size()) = x.segment(at, w1_.size());
    at += w1_.size();
    b1_ = x.segment(at, b1_.size());
    at += b1_.size();
    Eigen::Map<Eigen::VectorXd>(w2_.data(), w2_.size()) = x.segment(at, w2_.size());
    at += w2_.size();
    b2_ = x.segment(at, b2_.size());
}

namespace {

nn_kernels::NetworkView view_of(const Eigen::MatrixXd& w1, const Eigen::VectorXd& b1, const Eigen::MatrixXd& w2,
                                const Eigen::VectorXd& b2) {
    return {static_cast<int>(w1.cols()), static_cast<int>(w1.rows()), static_cast<int>(w2.rows()),
            w1.data(), b1.data(), w2.data(), b2.data()};
}

}  // namespace

std::string nn_kernels::variant() {
    const std::string simd = sim::simd_target().name;
    return simd == "avx512" || simd == "avx2" ? simd : "baseline";
}

Eigen::MatrixXd Network::forward(const Eigen::MatrixXd& x) const {
    if (x.rows() != inputs()) {
        throw EmadiagError("network input has " + std::to_string(x.rows()) + " rows, the network " +
                           std::to_string(inputs()) + " inputs");
    }
    Eigen::MatrixXd y(outputs(), x.cols());
    const nn_kernels::NetworkView n = view_of(w1_, b1_, w2_, b2_);
    const std::string v = nn_kernels::variant();
    if (v == "avx512") nn_kernels::avx512::forward(n, x.data(), x.cols(), y.data());
    else if (v == "avx2") nn_kernels::avx2::forward(n, x.data(), x.cols(), y.data());
    else nn_kernels::baseline::forward(n, x.data(), x.cols(), y.data());
    return y;
}

double Network::mse(const Eigen::MatrixXd& x, const Eigen::MatrixXd& t, Eigen::VectorXd* grad, MseCache* cache) const {
    if (x.rows() != inputs() || t.rows() != outputs() || x.cols() != t.cols() || x.cols() == 0) {
        throw EmadiagError("mse: inputs " + std::to_string(x.rows()) + "x" + std::to_string(x.cols()) + " and targets " +
                           std::to_string(t.rows()) + "x" + std::to_string(t.cols()) + " do not fit a " +
                           std::to_string(inputs()) + "-" + std::to_string(hidden()) + "-" + std::to_string(outputs()) +
                           " network");
    }
    double* g = nullptr;
    if (grad != nullptr) {
        grad->resize(parameter_count());
        g = grad->data();
    }
    const nn_kernels::NetworkView n = view_of(w1_, b1_, w2_, b2_);
    const std::string v = nn_kernels::variant();
    double* a1 = nullptr;
    double* z2 = nullptr;
    bool have_forward = false;
    if (cache != nullptr) {
        const Eigen::VectorXd w = flatten();
        have_forward = cache->valid && cache->x == x.data() && cache->cols == x.cols() && cache->variant == v &&
                       cache->weights.size() == static_cast<std::size_t>(w.size()) &&
                       std::equal(cache->weights.begin(), cache->weights.end(), w.data());
        if (!have_forward) {
            cache->weights.assign(w.data(), w.data() + w.size());
            cache->a1.resize(static_cast<std::size_t>(hidden()) * static_cast<std::size_t>(x.cols()));
            cache->z2.resize(static_cast<std::size_t>(outputs()) * static_cast<std::size_t>(x.cols()));
            cache->x = x.data();
            cache->cols = x.cols();
            cache->variant = v;
        } else {
            ++cache->hits;
        }
        cache->valid = true;
        a1 = cache->a1.data();
        z2 = cache->z2.data();
    }
    if (v == "avx512") return nn_kernels::avx512::mse(n, x.data(), t.data(), x.cols(), g, a1, z2, have_forward);
    if (v == "avx2") return nn_kernels::avx2::mse(n, x.data(), t.data(), x.cols(), g, a1, z2, have_forward);
    return nn_kernels::baseline::mse(n, x.data(), t.data(), x.cols(), g, a1, z2, have_forward);
}

nlohmann::json Network::to_json() const {
    return {{"inputs", inputs()},
            {"hidden", hidden()},
            {"outputs", outputs()},
            {"hidden_transfer", "tansig"},
            {"output_transfer", "satlins"},
            {"w1_column_major", to_vector(Eigen::Map<const Eigen::VectorXd>(w1_.data(), w1_.size()))},
            {"b1", to_vector(b1_)},
            {"w2_column_major", to_vector(Eigen::Map<const Eigen::VectorXd>(w2_.data(), w2_.size()))},
            {"b2", to_vector(b2_)}};
}

Network Network::from_json(const nlohmann::json& j, const std::string& where) {
    try {
        Network n(j.at("inputs").get<int>(), j.at("hidden").get<int>(), j.at("outputs").get<int>());
        n.w1_ = matrix_from_json(j.at("w1_column_major"), where + ".w1_column_major", n.w1_.rows(), n.w1_.cols());
        n.b1_ = vector_from_json(j.at("b1"), where + ".b1", n.b1_.size());
        n.w2_ = matrix_from_json(j.at("w2_column_major"), where + ".w2_column_major", n.w2_.rows(), n.w2_.cols());
        n.b2_ = vector_from_json(j.at("b2"), where + ".b2", n.b2_.size());
        return n;
    } catch (const nlohmann::json::exception& e) {
        throw EmadiagError(where + ": " + e.what());
    }
}

}  // namespace emadiag
