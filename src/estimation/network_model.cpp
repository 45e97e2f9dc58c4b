#include "estimation/network_model.hpp"

#include "core/emadiag_error.hpp"
#include "estimation/number_text.hpp"
#include "estimation/dataset.hpp"
#include "estimation/physics_friction_law.hpp"
#include "emadiag/io/bounded_json.hpp"
#include "emadiag/io/output_path.hpp"
#include "emadiag/sim/ema_params.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

namespace emadiag {
namespace {

constexpr const char* kFormatName = "emadiag-network";
constexpr double kEq4DerivativeStep = 1e-6;
/// The activations the network implements (Network::forward): what a model file may declare.
constexpr const char* kHiddenTransfer = "tansig";
constexpr const char* kOutputTransfer = "satlins";
/// A calibrated standard error, in normalised units, lies in (0, kMaxStdErrorNormalised]: 1 is the
/// whole section-8 range of the parameter, so a larger one says nothing, and zero or less is none.
constexpr double kMaxStdErrorNormalised = 1.0;
/// Problems listed in one error (all are counted).
constexpr std::size_t kMaxListedModelProblems = 20;


/// The semantic checks of a model file (issue 21 item 3): each problem names the field and value.
std::vector<std::string> model_problems(const nlohmann::json& j, const NetworkModel& m) {
    std::vector<std::string> out;
    const auto& net = j.at("network");
    const struct { const char* field; const char* expected; } transfers[] = {{"hidden_transfer", kHiddenTransfer},
                                                                              {"output_transfer", kOutputTransfer}};
    for (const auto& t : transfers) {
        if (net.contains(t.field) && (!net.at(t.field).is_string() || net.at(t.field).get<std::string>() != t.expected))
            out.push_back(std::string("network.") + t.field + " is " + net.at(t.field).dump() + ", expected \"" + t.expected +
                          "\" (the only one the network implements)");
    }
    for (std::size_t o = 0; o < m.std_error_normalised.size(); ++o) {
        const double se = m.std_error_normalised[o];
        if (!(std::isfinite(se) && se > 0 && se <= kMaxStdErrorNormalised))
            out.push_back("std_error_normalised[" + std::to_string(o) + "] (" +
                          (o < m.spec.outputs.size() ? m.spec.outputs[o] : std::string("?")) + ") = " + number_text(se) +
                          " is not in (0, " + number_text(kMaxStdErrorNormalised) + "] (normalised units: 1 is the whole section-8 range)");
    }
    for (std::size_t a = 0; a < m.spec.outputs.size(); ++a)
        for (std::size_t b = 0; b < a; ++b)
            if (m.spec.outputs[a] == m.spec.outputs[b])
                out.push_back("spec.outputs[" + std::to_string(a) + "] \"" + m.spec.outputs[a] + "\" repeats spec.outputs[" +
                              std::to_string(b) + "]");
    std::size_t bad_inputs = 0;
    for (Eigen::Index i = 0; i < m.input_norm.min.size() && i < m.input_norm.max.size(); ++i) {
        const double lo = m.input_norm.min(i), hi = m.input_norm.max(i);
        if (std::isfinite(lo) && std::isfinite(hi) && hi > lo) continue;
        if (bad_inputs++ < kMaxListedModelProblems)
            out.push_back("input_normalisation: input " + std::to_string(i) + " has min " + number_text(lo) + ", max " + number_text(hi) +
                          " (max must exceed min)");
    }
    if (bad_inputs > kMaxListedModelProblems)
        out.push_back("input_normalisation: ... " + std::to_string(bad_inputs - kMaxListedModelProblems) + " more inputs with max <= min");
    return out;
}

}  // namespace

nlohmann::json NetworkModel::to_json() const {
    return {{"format", kFormatName},
            {"version", kNetworkModelVersion},
            {"spec", spec.to_json()},
            {"input_normalisation", input_norm.to_json()},
            {"output_normalisation",
             [this] {
                 nlohmann::json o = nlohmann::json::array();
                 for (const auto& name : spec.outputs) {
                     const HealthRange r = health_range(name);
                     o.push_back({{"name", name}, {"lo", r.lo}, {"hi", r.hi}});
                 }
                 return o;
             }()},
            {"std_error_normalised", std_error_normalised},
            {"network", network.to_json()},
            {"training", training}};
}

NetworkModel NetworkModel::from_json(const nlohmann::json& j, const std::string& where) {
    NetworkModel m;
    try {
        if (j.at("format").get<std::string>() != kFormatName) {
            throw EmadiagError(where + ": field format is " + j.at("format").dump() + ", expected \"" + kFormatName + "\"");
        }
        const int version = j.at("version").get<int>();
        if (version != kNetworkModelVersion) {
            throw EmadiagError(where + ": field version " + std::to_string(version) + " is not supported (expected " +
                               std::to_string(kNetworkModelVersion) + ")");
        }
        m.spec = NetworkSpec::from_json(j.at("spec"), where + ".spec");
        m.input_norm = InputNormalisation::from_json(j.at("input_normalisation"), where + ".input_normalisation");
        m.network = Network::from_json(j.at("network"), where + ".network");
        m.std_error_normalised = j.at("std_error_normalised").get<std::vector<double>>();
        if (j.contains("training")) m.training = j.at("training");
        for (const auto& o : j.at("output_normalisation")) {
            const std::string name = o.at("name").get<std::string>();
            const HealthRange r = health_range(name);
            if (o.at("lo").get<double>() != r.lo || o.at("hi").get<double>() != r.hi) {
                throw EmadiagError(where + ".output_normalisation: range of " + name + " differs from section 8 [" +
                                   std::to_string(r.lo) + ", " + std::to_string(r.hi) + "]");
            }
        }
    } catch (const nlohmann::json::exception& e) {
        throw EmadiagError(where + ": " + e.what());
    }
    const auto outputs = static_cast<std::size_t>(m.network.outputs());
    if (m.network.inputs() != m.spec.input_count() || outputs != m.spec.outputs.size() ||
        m.input_norm.min.size() != m.spec.input_count() || m.std_error_normalised.size() != outputs ||
        m.network.hidden() != m.spec.hidden_neurons) {
        throw EmadiagError(where + ": sizes disagree: spec inputs " + std::to_string(m.spec.input_count()) +
                           ", network inputs " + std::to_string(m.network.inputs()) + ", normalisation " +
                           std::to_string(m.input_norm.min.size()) + ", outputs " + std::to_string(outputs) +
                           ", std errors " + std::to_string(m.std_error_normalised.size()));
    }
    const std::vector<std::string> problems = model_problems(j, m);
    if (!problems.empty()) {
        std::string msg = where + ": " + std::to_string(problems.size()) + " problem(s) in the network model:";
        for (const auto& p : problems) msg += "\n  " + p;
        throw EmadiagError(msg);
    }
    return m;
}

NetworkModel NetworkModel::load(const std::string& path) {
    std::string error;
    const auto j = io::read_bounded_json_file(path, error);
    if (!j) throw EmadiagError(error == "cannot open" ? "cannot open network model " + path : path + ": " + error);
    return from_json(*j, path);
}

void NetworkModel::save(const std::string& path, const io::OutputInputs& inputs) const {
    io::write_output_file<EmadiagError>(path, "network model", inputs, to_json().dump() + "\n");
}

std::vector<double> NetworkModel::predict_normalised(const Run& run) const {
    if (run.load_case != spec.load_case || run.sequence != spec.sequence) {
        throw EmadiagError("the network model was trained on case " + sim::to_string(spec.load_case) + ", sequence " +
                           sim::to_string(spec.sequence) + "; the run is case " + sim::to_string(run.load_case) +
                           ", sequence " + sim::to_string(run.sequence));
    }
    const Eigen::VectorXd x = network_features(run, spec);
    for (Eigen::Index i = 0; i < x.size(); ++i) {
        if (!std::isfinite(x(i))) throw EmadiagError("network input " + std::to_string(i) + " is not finite");
    }
    const Eigen::MatrixXd y = network.forward(input_norm.apply(x));
    std::vector<double> u(static_cast<std::size_t>(y.rows()));
    for (Eigen::Index o = 0; o < y.rows(); ++o) u[static_cast<std::size_t>(o)] = from_internal(y(o, 0));
    return u;
}

HealthEstimate NetworkModel::estimate(const Run& run) const {
    const std::vector<double> u = predict_normalised(run);
    HealthEstimate h;
    h.estimator = EstimatorMethod::Network;
    const auto predicted = [&](const std::string& name) -> std::optional<std::size_t> {
        for (std::size_t o = 0; o < spec.outputs.size(); ++o) {
            if (spec.outputs[o] == name) return o;
        }
        return std::nullopt;
    };
    const std::string why = "not identifiable: the network (case " + sim::to_string(spec.load_case) + ") does not predict it";
    for (const HealthParameter parameter : kHealthParameters) {
        const char* name = to_string(parameter);
        ParameterEstimate p;
        p.name = name;
        p.method = "network";
        if (const auto o = predicted(name)) {
            const HealthRange r = health_range(name);
            p.value = r.denormalise(u[*o]);
            p.std_error = std_error_normalised[*o] * (r.hi - r.lo);
        } else if (parameter == HealthParameter::EtaA && predicted(kParamEtaO)) {
            const std::size_t eo = *predicted(kParamEtaO);
            const HealthRange r = health_range(kParamEtaO);
            const double eta_o = r.denormalise(u[eo]);
            const double tau = run.constants.tau;
            p.value = sim::eta_a_from_eta_o(eta_o, tau);  // eq. (4)
            const double slope = eta_a_derivative_central(eta_o, tau, kEq4DerivativeStep);
            p.std_error = std::abs(slope) * std_error_normalised[eo] * (r.hi - r.lo);
            p.method = "eq4";
            p.note = "from the network's eta_O by eq. (4)";
        } else {
            p.identifiable = false;
            p.note = why;
        }
        h.parameters.push_back(std::move(p));
    }
    // A model's uncertainty is calibrated for the noise of its training runs; say so when the run's
    // declared noise profile differs (real runs declare none and get no note).
    const auto run_noise = run.meta_value("noise");
    if (run_noise && training.contains("noise") && training.at("noise").is_string() &&
        training.at("noise").get<std::string>() != *run_noise) {
        const std::string warn = "model trained on noise " + training.at("noise").get<std::string>() +
                                 ", the run declares noise " + *run_noise + ": the uncertainty may be understated";
        for (auto& p : h.parameters) {
            if (p.value) p.note = p.note.empty() ? warn : p.note + "; " + warn;
        }
    }
    h.diagnostics.emplace_back("timesteps", spec.timesteps);
    h.diagnostics.emplace_back("hidden_neurons", spec.hidden_neurons);
    return h;
}

}  // namespace emadiag
