// emadiag discover RUN.csv [--json] [--out-model FILE] [--out-params FILE] [--max-effects N]:
// the residual between the run and the datasheet model with the run's estimated health, traced to
// an effect the model lacks, that effect added and fitted by re-simulation, and the error before
// and after (docs/discovery.md). --out-model writes the augmented model JSON (apply_model reads
// it); --out-params writes its sim::EmaParams JSON, which `emadiag simulate --params` reads.
#include "cli/command.hpp"
#include "core/emadiag_error.hpp"
#include "core/run_csv.hpp"
#include "discovery/candidate_effect.hpp"
#include "discovery/discovery.hpp"
#include "emadiag/io/output_path.hpp"

#include <nlohmann/json.hpp>

#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

namespace emadiag::cli {
namespace {

std::string fmt(double v, int digits = 4) {
    std::ostringstream os;
    os << std::setprecision(digits) << v;
    return os.str();
}

void print_errors(std::ostream& os, const char* label, const discovery::ErrorMetrics& e) {
    os << "  " << std::left << std::setw(7) << label << "current " << fmt(e.current_rms_a) << " A RMS, T_R "
       << fmt(e.residual_torque_rms_nm) << " N m RMS (" << fmt(e.residual_torque_window_rms_nm) << " N m in means of "
       << discovery::kMetricWindowSamples << "), speed " << fmt(e.speed_rms_rad_s) << " rad/s, theta "
       << fmt(e.theta_rms_rad) << " rad\n";
}

void print_text(std::ostream& os, const std::string& path, const discovery::DiscoveryReport& r) {
    os << "run " << path << ": case " << r.load_case << ", sequence " << r.sequence << ", " << r.samples << " samples\n";
    os << "baseline model: " << discovery::kModelBase << " with\n";
    for (const auto& h : r.baseline_health) {
        os << "  " << std::left << std::setw(7) << h.name << fmt(h.value, 6) << " (" << h.source;
        if (h.std_error > 0) os << ", se " << fmt(h.std_error, 3);
        os << ")\n";
    }
    int round = 0;
    for (const auto& s : r.steps) {
        os << "\nscreening " << ++round << ": " << s.screen.samples << " samples, residual " << fmt(s.screen.base_rms_nm)
           << " N m RMS (means of " << discovery::kScreenWindowSamples << ") after the base columns\n";
        for (std::size_t i = 0; i < s.screen.ranking.size(); ++i) {
            const auto& c = s.screen.ranking[i];
            std::string verdict = "  rejected: " + c.reason;
            if (c.accepted && i == 0 && s.added) verdict = "  ADDED";
            else if (c.accepted && i == 0 && !s.rejected_by_fit.empty()) verdict = "  passes; NOT confirmed by the fit";
            else if (c.accepted) verdict = "  passes (the best is added first)";
            const std::string shape = discovery::shape_text(c.shape);
            os << "  " << std::left << std::setw(19) << discovery::effect_name(c.shape.kind) << " dBIC " << std::setw(9)
               << fmt(c.delta_bic) << " peak " << std::setw(9) << fmt(c.peak_torque_nm) << " N m, explains " << std::setw(9) << fmt(c.explained_rms_nm) << " N m  a = "
               << fmt(c.amplitude) << " +/- " << fmt(c.amplitude_se, 2) << (shape.empty() ? "" : "  (" + shape + ")")
               << verdict << '\n';
        }
        if (!s.rejected_by_fit.empty()) os << "  " << s.rejected_by_fit << '\n';
        if (s.added) {
            os << "  added " << discovery::effect_name(s.added->kind) << "; re-simulation fit (" << s.simulations
               << " simulations):";
            for (const auto& f : s.fitted) os << ' ' << f.name << '=' << fmt(f.value, 5) << " +/- " << fmt(f.std_error, 2);
            os << '\n';
        }
    }
    const auto added = r.added_effects();
    os << '\n' << (added.empty() ? "no missing effect found" : "added effects:");
    for (const auto& a : added) os << ' ' << a;
    os << '\n';
    if (!added.empty()) {
        os << "model: health refit with the added effects\n";
        for (const auto& h : r.model.health) {
            os << "  " << std::left << std::setw(7) << h.name << fmt(h.value, 6) << " (" << h.source;
            if (h.std_error > 0) os << ", se " << fmt(h.std_error, 3);
            os << ")\n";
        }
        for (const auto& t : r.model.terms) {
            os << "  " << std::left << std::setw(22) << t.effect << fmt(t.value, 6);
            if (t.std_error > 0) os << " (se " << fmt(t.std_error, 3) << ")";
            os << '\n';
        }
    }
    os << "error (measured - model):\n";
    print_errors(os, "before", r.model.error_before);
    print_errors(os, "after", r.model.error_after);
    const auto& b = r.model.error_before;
    const auto& a = r.model.error_after;
    if (!added.empty()) {
        os << "  ratio before/after: current " << fmt(b.current_rms_a / a.current_rms_a, 3) << ", T_R "
           << fmt(b.residual_torque_rms_nm / a.residual_torque_rms_nm, 3) << ", T_R means "
           << fmt(b.residual_torque_window_rms_nm / a.residual_torque_window_rms_nm, 3) << '\n';
    }
    for (const auto& n : r.notes) os << "note: " << n << '\n';
}

void write_json_file(const std::string& path, const nlohmann::json& j) {
    if (const auto problem = io::output_path_problem(path, "JSON output")) throw EmadiagError(*problem);
    std::ofstream out(path);
    if (!out) throw EmadiagError("cannot write " + path);
    out << j.dump(2) << '\n';
    if (!out) throw EmadiagError("error writing " + path);
}

const bool registered = register_command(Command{
    "discover", "Trace the residual between a run and the model to a missing effect, add it, report the error before/after",
    [](CLI::App& sub) -> std::function<int()> {
        auto path = std::make_shared<std::string>();
        auto out_model = std::make_shared<std::string>();
        auto out_params = std::make_shared<std::string>();
        auto json = std::make_shared<bool>(false);
        auto max_effects = std::make_shared<int>(discovery::kMaxEffects);
        sub.add_option("run", *path, "Run CSV")->required();
        sub.add_flag("--json", *json, "Print the report as JSON (docs/discovery.md)");
        sub.add_option("--out-model", *out_model, "Write the augmented model JSON here");
        sub.add_option("--out-params", *out_params, "Write the model's simulator parameters (for simulate --params)");
        sub.add_option("--max-effects", *max_effects, "Most effects to add")->check(CLI::Range(0, discovery::kMaxEffects));
        return [=] {
            const Run run = read_run_csv_file(*path);
            discovery::DiscoveryOptions opt;
            opt.max_effects = *max_effects;
            const discovery::DiscoveryReport r = discovery::discover(run, opt);
            if (!out_model->empty()) write_json_file(*out_model, r.model.to_json());
            if (!out_params->empty()) write_json_file(*out_params, r.model.params.to_json());
            if (*json) std::cout << r.to_json().dump(2) << '\n';
            else print_text(std::cout, *path, r);
            return 0;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
