// emadiag estimate RUN.csv|RUN.log [--model FILE] [--json]: health parameters of one run, by the
// physics estimator (always) and the paper's network (with --model, or a shipped model in
// models/ for the run's case and sequence). Text for people; --json is the stable schema of
// docs/estimate-json.md. --model may also name an augmented model that `emadiag discover` wrote:
// its effects and terms are removed from the run first (discovery/model_correction.hpp), the
// estimators then fit the datasheet law to what is left, and the file with its SHA-256 is listed.
#include "cli/command.hpp"
#include "emadiag/io/text_field.hpp"
#include "cli/run_file.hpp"
#include "core/emadiag_error.hpp"
#include "core/run_csv.hpp"
#include "core/run_validity.hpp"
#include "can_tool/candump_run.hpp"
#include "discovery/model/augmented_model.hpp"
#include "discovery/model/model_correction.hpp"
#include "emadiag/db/sha256.hpp"
#include "emadiag/io/bounded_json.hpp"
#include "estimation/health_estimate.hpp"
#include "estimation/run_checks.hpp"
#include "estimation/run_estimator.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <utility>

namespace emadiag::cli {
namespace {

/// Version of the --json schema (docs/estimate-json.md).
constexpr int kEstimateJsonVersion = 1;

/// The file line of the first data row of a run CSV (after the `# key=value` lines and the header).
std::optional<int> first_data_line(const std::string& path) {
    if (!ends_with(path, ".csv")) return std::nullopt;
    std::ifstream in(path);
    std::string line;
    int n = 0;
    while (std::getline(in, line)) {
        ++n;
        if (!line.empty() && line[0] == '#') continue;
        return n + 1;  // this is the header row
    }
    return std::nullopt;
}


std::string fmt(double v, int digits) {
    std::ostringstream os;
    os << std::setprecision(digits) << v;
    return os.str();
}

/// The run read from `path`, checked where it enters (estimation/run_checks.hpp); a problem in a
/// sample row also says which file line holds that row.
CheckedRun checked_run_of_file(const std::string& path, Run run) {
    try {
        return check_run(std::move(run));
    } catch (const EmadiagError& e) {
        // Rows are numbered in sample order; say where they are in a CSV file.
        const auto line = first_data_line(path);
        if (!line) throw;
        std::string msg = e.what();
        const std::string prefix = "[emadiag] ";
        if (msg.rfind(prefix, 0) == 0) msg.erase(0, prefix.size());
        throw EmadiagError(msg + "\n  (" + path + ": sample row 1 is line " + std::to_string(*line) +
                           ", so sample row N is line N + " + std::to_string(*line - 1) + ")");
    }
}

/// The loud warning for a run that may give no verdict, printed before and after the estimates.
std::string invalid_warning(const RunValidity& v) {
    return "WARNING: RUN NOT VALID: " + io::escape_text(v.reason) + ". The estimates are for information only; no verdict is possible from this run.";
}

void print_text(std::ostream& os, const std::string& path, const Run& run, const RunValidity& validity, const RunEstimates& out) {
    os << "run " << io::escape_text(path) << ": case " << sim::to_string(run.load_case) << ", sequence " << sim::to_string(run.sequence) << ", "
       << run.samples.size() << " samples\n";
    if (!validity.valid) os << invalid_warning(validity) << '\n';
    for (const auto& h : out.estimates) {
        os << "\nestimator: " << to_string(h.estimator) << '\n';
        for (const auto& p : h.parameters) {
            os << "  " << std::left << std::setw(7) << p.name << ' ';
            if (p.value) {
                const double lo = *p.value - kZ95 * p.std_error;
                const double hi = *p.value + kZ95 * p.std_error;
                os << std::setw(11) << fmt(*p.value, 6) << " +/- " << std::setw(10) << fmt(p.std_error, 3)
                   << " (1 se; 95 % [" << fmt(lo, 6) << ", " << fmt(hi, 6) << "])  [" << p.method << "]";
            } else {
                os << std::setw(11) << (p.identifiable ? "not estimated" : "not identifiable") << "  [" << p.method
                   << "]";
            }
            if (!p.note.empty()) os << "  " << p.note;
            os << '\n';
        }
        if (!h.diagnostics.empty()) {
            os << "  diagnostics:";
            for (const auto& [k, v] : h.diagnostics) os << ' ' << k << '=' << fmt(v, 6);
            os << '\n';
        }
    }
    for (const auto& f : out.model_files) os << "model: " << io::escape_text(f) << '\n';
    for (const auto& n : out.notes) os << "note: " << io::escape_text(n) << '\n';
    // Agreement between the methods, parameter by parameter.
    if (out.estimates.size() == 2) {
        os << "\nagreement (|difference| / combined se):\n";
        for (const auto& p : out.estimates[0].parameters) {
            const auto z = agreement_z(out.estimates[0], out.estimates[1], p.name);
            if (!z) continue;
            os << "  " << std::left << std::setw(7) << p.name << ' ' << fmt(*z, 3)
               << (*z <= kZ95 ? "  agree" : "  DISAGREE") << '\n';
        }
    }
    if (!validity.valid) os << '\n' << invalid_warning(validity) << '\n';
}

nlohmann::json to_json(const std::string& path, const Run& run, const RunValidity& validity, const RunEstimates& out) {
    nlohmann::json j;
    j["schema"] = "emadiag-estimate";
    j["version"] = kEstimateJsonVersion;
    j["run"] = {{"path", path}, {"case", sim::to_string(run.load_case)}, {"sequence", sim::to_string(run.sequence)}, {"samples", run.samples.size()},
                {"valid", validity.valid}};
    if (!validity.valid) j["run"]["invalid_reason"] = validity.reason;
    j["estimates"] = nlohmann::json::array();
    for (const auto& h : out.estimates) {
        nlohmann::json e;
        e["estimator"] = to_string(h.estimator);
        e["parameters"] = nlohmann::json::array();
        for (const auto& p : h.parameters) {
            nlohmann::json q;
            q["name"] = p.name;
            q["value"] = p.value ? nlohmann::json(*p.value) : nlohmann::json(nullptr);
            q["std_error"] = p.value ? nlohmann::json(p.std_error) : nlohmann::json(nullptr);
            q["ci95"] = p.value ? nlohmann::json::array({*p.value - kZ95 * p.std_error,
                                                         *p.value + kZ95 * p.std_error})
                                : nlohmann::json(nullptr);
            q["identifiable"] = p.identifiable;
            q["method"] = p.method;
            q["note"] = p.note;
            e["parameters"].push_back(q);
        }
        e["diagnostics"] = nlohmann::json::object();
        for (const auto& [k, v] : h.diagnostics) e["diagnostics"][k] = std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
        j["estimates"].push_back(e);
    }
    j["models"] = out.model_files;
    j["notes"] = out.notes;
    return j;
}

const bool registered = register_command(Command{
    "estimate", "Estimate FDJ, FSJ, eta_O and eta_A of a run (physics estimator, and the network if a model applies)",
    [](CLI::App& sub) -> std::function<int()> {
        auto path = std::make_shared<std::string>();
        auto model = std::make_shared<std::string>();
        auto json = std::make_shared<bool>(false);
        sub.add_option("run", *path, "Run file: RUN.csv (run CSV) or RUN.log (candump)")->required();
        sub.add_option("--model", *model, "Network model JSON (default: a shipped model in models/ for the run's case), or "
                                          "an augmented model JSON from `emadiag discover` (its terms are removed from the run first)");
        sub.add_flag("--json", *json, "Print the stable JSON schema of docs/estimate-json.md");
        return [path, model, json] {
            const CheckedRun checked = checked_run_of_file(*path, read_run_any(*path));
            const Run& run = checked.run();
            // Only a complete, valid run may give a verdict (core/run_validity.hpp): estimates of any
            // other are printed with a warning on both streams (stderr first, before anything can fail).
            const RunValidity validity = run_validity(run);
            if (!validity.valid) std::cerr << "emadiag estimate: " << invalid_warning(validity) << '\n';
            std::optional<std::string> network_model = model->empty() ? std::nullopt : std::optional<std::string>(*model);
            std::optional<Run> corrected;
            std::string model_note;
            if (network_model) {
                std::string error;
                const auto j = io::read_bounded_json_file(*network_model, error);
                if (!j) throw EmadiagError("--model " + *network_model + ": " + error);
                if (discovery::is_discovery_model(*j)) {
                    sim::EmaParams params = sim::EmaParams::datasheet();
                    params.k_t_nm_per_a = run.constants.k_t_nm_per_a;
                    params.j_kgm2 = run.constants.j_kgm2;
                    params.tau = run.constants.tau;
                    try {
                        discovery::apply_model(*j, params);
                        const discovery::ModelCorrection c = discovery::model_correction(params);
                        corrected = discovery::remove_model_effects(run, c);
                        model_note = "discovery model " + *network_model + " (sha256 " + db::sha256_file_hex(*network_model) +
                                     "): removed from the run before estimation: " + c.text();
                    } catch (const std::exception& e) {
                        throw EmadiagError("--model " + *network_model + ": " + e.what());
                    }
                    network_model.reset();  // the network: a shipped model for the run's case
                }
            }
            // The corrected run is a new run: it is checked as it is made.
            RunEstimates out = corrected ? estimate_run(check_run(std::move(*corrected)), network_model)
                                         : estimate_run(checked, network_model);
            if (corrected) {
                out.model_files.insert(out.model_files.begin(), *model);
                out.notes.insert(out.notes.begin(), model_note);
            }
            if (*json) std::cout << to_json(*path, run, validity, out).dump(2) << '\n';
            else print_text(std::cout, *path, run, validity, out);
            return 0;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
