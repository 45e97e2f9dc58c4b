// emadiag discover RUN.csv... | --db FILE --tail T --position POS [--serial SN] [--json] [--out-model FILE] [--out-params FILE]
//                  [--max-effects N] [--plot FILE.svg]:
// the residual between the run and the datasheet model with the run's estimated health, traced to
// an effect the model lacks, that effect added and fitted by re-simulation, and the error before
// and after (docs/discovery.md). --out-model writes the augmented model JSON (apply_model reads
// it); --out-params writes its sim::EmaParams JSON, which `emadiag simulate --params` reads.
#include "cli/command.hpp"
#include "cli/db_source.hpp"
#include "core/emadiag_error.hpp"
#include "core/run_csv.hpp"
#include "discovery/screening/candidate_effect.hpp"
#include "discovery/discovery.hpp"
#include "discovery/many_run/multi_run.hpp"
#include "discovery/physics_names.hpp"
#include "discovery/residual_plot.hpp"
#include "emadiag/db/database.hpp"
#include "emadiag/db/run_store.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/session_store.hpp"
#include "emadiag/sim/simulator.hpp"
#include "emadiag/io/output_path.hpp"
#include "emadiag/io/text_field.hpp"
#include "emadiag/io/utc_now.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

namespace emadiag::cli {
namespace {

/// Families of the generated library shown per screening in the text report.
constexpr std::size_t kTextGenericRanking = 3;

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
    os << "run " << path << ": case " << sim::to_string(r.load_case) << ", sequence " << sim::to_string(r.sequence) << ", " << r.samples << " samples\n";
    if (const std::string window = r.analysis_text(); !window.empty()) os << window << '\n';  // a long run's cost, stated
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
        for (std::size_t i = 0; i < s.generic.ranking.size() && i < kTextGenericRanking; ++i) {
            const auto& g = s.generic.ranking[i];
            std::string terms;
            for (const auto& t : g.terms) terms += (terms.empty() ? "" : " + ") + fmt(t.coefficient) + "*" + t.basis_text();
            os << "  generated " << std::left << std::setw(27) << g.family << " dBIC " << std::setw(9) << fmt(g.delta_bic)
               << " peak " << std::setw(9) << fmt(g.peak_torque_nm) << " N m  " << terms << "  "
               << (g.accepted ? "passes" : "rejected") << ": " << g.reason << '\n';
        }
        if (s.generic.shapes > 0) {
            os << "  (generated library: " << s.generic.shapes << " shapes; " << (s.generic.ranking.size() > kTextGenericRanking ? s.generic.ranking.size() - kTextGenericRanking : 0)
               << " further families not shown)\n";
        }
        if (!s.hypotheses.empty()) {
            os << "  hypotheses with the same torque residual, told apart by the re-simulated trajectory (cost 1 = noise floor):\n";
            for (const auto& h : s.hypotheses) {
                os << "    " << std::left << std::setw(24) << h.key << " cost " << std::setw(9) << fmt(h.cost) << " current "
                   << fmt(h.error.current_a) << " A, speed " << fmt(h.error.speed_rad_s) << " rad/s, theta "
                   << fmt(h.error.theta_rad) << " rad, load " << fmt(h.error.load_nm) << " N m  (" << h.change << ")"
                   << (h.refit_on_trajectory ? " [cost after a refit on the trajectory]" : "") << '\n';
            }
            os << "    " << (s.equivalent ? "EQUIVALENT on this run: both are reported" : "told apart: " + s.hypotheses.front().key)
               << '\n';
        }
        if (!s.rejected_by_fit.empty()) os << "  " << s.rejected_by_fit << '\n';
        if (!s.withheld.empty()) os << "  " << s.withheld << '\n';
        if (s.added || !s.added_terms.empty()) {
            os << "  added " << s.name_key << " (" << s.name_text << "); re-simulation fit (" << s.simulations
               << " simulations):";
            for (const auto& f : s.fitted) os << ' ' << f.name << '=' << fmt(f.value, 5) << " +/- " << fmt(f.std_error, 2);
            os << '\n';
        }
    }
    if (r.low_speed.ran) {
        const auto& ls = r.low_speed;
        os << "\nlow-speed friction by the trajectory (" << ls.rows << " rows in noise floors; cost " << fmt(ls.cost_before)
           << ", " << fmt(ls.base_cost) << " after the model's own parameters, linearised):\n";
        for (std::size_t i = 0; i < ls.ranking.size() && i < kTextGenericRanking; ++i) {
            const auto& ev = ls.ranking[i];
            os << "  stribeck w_s = " << std::left << std::setw(8) << fmt(ev.stribeck_speed_rad_s, 4) << " rad/s  dBIC "
               << std::setw(9) << fmt(ev.delta_bic) << " a = " << fmt(ev.amplitude_nm) << " +/- " << fmt(ev.amplitude_se_nm, 2)
               << " N m\n";
        }
        os << "  " << ls.verdict << '\n';
        if (ls.added) {
            os << "  " << (ls.refit_of_torque ? "stribeck re-estimated on the trajectory (replaces the torque fit)"
                                              : "added stribeck (Stribeck friction, found by the trajectory)")
               << "; profile over w_s and re-simulation fit on the trajectory (" << ls.simulations << " simulations):";
            for (const auto& f : ls.fitted) os << ' ' << f.name << '=' << fmt(f.value, 5) << " +/- " << fmt(f.std_error, 2);
            os << '\n';
        }
    }
    if (r.efficiency.ran) {
        const auto& ea = r.efficiency;
        os << "\nefficiency or friction (eta_O " << fmt(ea.eta_o, 5) << " +/- " << fmt(ea.eta_o_se, 2) << ", datasheet "
           << fmt(ea.eta_o_datasheet, 5) << "):\n  " << ea.verdict << '\n';
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
        for (std::size_t i = 0; i < r.model.params.terms.size(); ++i) {
            const auto& t = r.model.params.terms[i];
            os << "  " << t.text() << " (se " << fmt(t.std_error, 3) << "): "
               << (i < r.model.term_texts.size() ? r.model.term_texts[i] : discovery::physics_name(t).text) << '\n';
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
    os << "trajectory cost (mean over current, speed, theta, load of (RMS / noise floor)^2): before "
       << fmt(r.trajectory_before.cost) << ", after " << fmt(r.trajectory_after.cost) << '\n';
    os << "noise floor of this run: current " << fmt(r.floor.current_a, 3) << " A, speed " << fmt(r.floor.speed_rad_s, 3)
       << " rad/s, theta " << fmt(r.floor.theta_rad, 3) << " rad, torque window means " << fmt(r.floor.torque_window_nm, 3)
       << " N m\n";
    if (const auto* u = r.unexplained()) {
        os << "UNEXPLAINED STRUCTURE in the " << u->channel << " residual: " << discovery::structure_test_text(*u) << '\n';
        os << "  depends most on (binned variance explained):";
        for (std::size_t i = 0; i < u->dependence.size() && i < 4; ++i) {
            os << ' ' << u->dependence[i].variable << ' ' << fmt(u->dependence[i].variance_explained, 2);
        }
        os << '\n';
    }
    os << "summary: " << r.summary() << '\n';
    for (const auto& n : r.notes) os << "note: " << n << '\n';
}

/// The SVG of the unexplained structure, or of the torque residual when it is consistent with noise.
std::string plot_of(const discovery::DiscoveryReport& r, const std::string& label) {
    const discovery::StructureReport* u = r.unexplained();
    const discovery::StructureReport* shown = u;
    if (shown == nullptr && !r.structure.empty()) shown = &r.structure.front();
    if (shown == nullptr || shown->x.empty()) throw EmadiagError("discover --plot: no residual to plot for " + label);
    discovery::ResidualPlot p;
    p.title = label + ": " + (u != nullptr ? "unexplained structure in the " : "consistent with noise: the ") + shown->channel +
              " residual (" + fmt(shown->rms / shown->floor, 3) + " x the noise floor)";
    p.x_label = shown->dependence.empty() ? "?" : shown->dependence.front().variable;
    p.y_label = shown->channel + " residual, measured - model (" + shown->unit + ")" +
                (shown->channel == "torque" ? ", means of 8 samples" : "");
    p.x = shown->x;
    p.y = shown->y;
    p.floor = shown->floor;
    return discovery::residual_svg(p);
}

/// A stored run as a Run (samples, constants, case, sequence, metadata).
Run run_from_stored(const db::StoredRun& s) {
    Run r;
    r.constants = RunConstants{s.k_t_nm_per_a, s.j_kgm2, s.tau, s.sample_period_s};
    r.load_case = sim::parse_load_case(s.load_case);  // the database's text, by the one parser
    r.sequence = sim::parse_sequence(s.sequence);
    const nlohmann::json meta = nlohmann::json::parse(s.meta_json, nullptr, false);
    if (meta.is_object()) {
        for (const auto& [k, v] : meta.items()) r.set_meta(k, v.is_string() ? v.get<std::string>() : v.dump());
    }
    r.set_required_meta();
    r.samples = s.samples;
    return r;
}

/// The files discover reads: the run CSVs and the database (none of them may be an output).
io::OutputInputs discover_inputs(const std::vector<std::string>& paths, const std::string& db_path) {
    io::OutputInputs inputs(paths);
    if (!db_path.empty()) inputs.databases.push_back(db_path);
    return inputs;
}

/// The stored runs of ONE actuator (docs/discovery.md, "Findings in the maintenance record"): the
/// valid runs of the tail's sessions at `position`, of `serial` when given; without it the position
/// must have held one serial only. Sets `serial` to the actuator's. Throws naming what is missing or
/// ambiguous; says on stderr which runs were left out and why. `where` gets the position's record.
std::vector<std::pair<db::StoredRun, std::string>> actuator_runs(db::Database& database, const std::string& tail,
                                                                 const std::string& position, std::string& serial,
                                                                 db::StoredDiscoveryFinding& where) {
    std::vector<std::pair<db::StoredRun, std::string>> listed;  // the run (no samples) and its serial
    std::vector<std::string> serials;
    std::size_t other_serial = 0, invalid = 0;
    for (const auto& session : db::list_test_sessions(database, tail)) {
        if (session.position.value_or("") != position) continue;
        where.position = position;
        where.position_ata = session.position_ata;
        where.position_description = session.position_description;
        for (const auto& r : session.runs) {
            const std::string sn = !r.actuator_serial.empty() ? r.actuator_serial : session.actuator_serial;
            if (!serial.empty() && sn != serial) {
                ++other_serial;
                continue;
            }
            if (!r.valid) {
                ++invalid;
                continue;
            }
            if (std::find(serials.begin(), serials.end(), sn) == serials.end()) serials.push_back(sn);
            listed.emplace_back(r, sn);
        }
    }
    if (other_serial > 0) std::cerr << "discover: left out " << other_serial << " run(s) of another serial at " << tail << ' ' << position << '\n';
    if (invalid > 0) std::cerr << "discover: left out " << invalid << " run(s) stored as not valid (truncated, incomplete or aborted)\n";
    if (listed.empty())
        throw EmadiagError("discover: tail " + tail + " has no valid stored run at position " + position +
                           (serial.empty() ? std::string() : " of serial " + serial));
    if (serials.size() > 1) {
        std::string all;
        for (const auto& sn : serials) all += (all.empty() ? "" : ", ") + (sn.empty() ? std::string("(none)") : sn);
        throw EmadiagError("discover: position " + position + " of " + tail + " held " + std::to_string(serials.size()) +
                           " actuators (serials " + all + "); give --serial SN: a finding belongs to one actuator");
    }
    serial = serials.front();
    return listed;
}

/// A run file given with --db/--tail must be a run of that actuator: its metadata names the serial
/// (ema_serial_number) and, when it names a tail (tail_number), the same tail.
void check_run_of_actuator(const Run& run, const std::string& path, const std::string& tail, const std::string& position,
                           const std::string& serial) {
    const std::string sn = run.meta_value("ema_serial_number").value_or("");
    const std::string t = run.meta_value("tail_number").value_or(tail);
    if (sn.empty() || sn != serial || t != tail) {
        throw EmadiagError(path + ": the run names " + (sn.empty() ? std::string("no serial (no ema_serial_number key)") : "serial " + sn) +
                           (t != tail ? " and tail " + t : std::string()) + ", not the actuator " + (serial.empty() ? "(no serial)" : serial) +
                           " at " + tail + " " + position + "; a run of another actuator is not mixed into its finding");
    }
}

void write_text_file(const std::string& path, const std::string& text, const io::OutputInputs& inputs) {
    io::write_output_file<EmadiagError>(path, "SVG plot", inputs, text);
}

void write_json_file(const std::string& path, const nlohmann::json& j, const io::OutputInputs& inputs) {
    io::write_output_file<EmadiagError>(path, "JSON output", inputs, j.dump(2) + "\n");
}

const bool registered = register_command(Command{
    "discover", "Trace the residual between run(s) and the model to what the model lacks, add it, report the error before/after",
    [](CLI::App& sub) -> std::function<int()> {
        auto paths = std::make_shared<std::vector<std::string>>();
        auto out_model = std::make_shared<std::string>();
        auto out_params = std::make_shared<std::string>();
        auto plot = std::make_shared<std::string>();
        auto db_path = std::make_shared<std::string>();
        auto tail = std::make_shared<std::string>();
        auto json = std::make_shared<bool>(false);
        auto max_effects = std::make_shared<int>(discovery::kMaxEffects);
        sub.add_option("runs", *paths, "Run CSV file(s); several runs are also screened together");
        sub.add_option("--db", *db_path, "Maintenance database (with --tail)")->check(sqlite_file());
        sub.add_option("--tail", *tail, "Take the tail's stored runs from the database (oldest first)");
        auto position = std::make_shared<std::string>();
        auto serial = std::make_shared<std::string>();
        auto finding_place = std::make_shared<db::StoredDiscoveryFinding>();  // tail position and its ATA reference
        sub.add_option("--position", *position, "With --tail: the actuator's position (only its runs are used; the finding is stored under it)");
        sub.add_option("--serial", *serial, "With --tail: the actuator's serial (needed when the position held more than one)");
        sub.add_flag("--json", *json, "Print the report as JSON (docs/discovery.md)");
        sub.add_option("--out-model", *out_model, "Write the augmented model JSON here");
        sub.add_option("--out-params", *out_params, "Write the model's simulator parameters (for simulate --params)");
        sub.add_option("--plot", *plot, "Write an SVG of the residual against the variable it depends on most");
        sub.add_option("--max-effects", *max_effects, "Most effects to add")->check(CLI::Range(0, discovery::kMaxEffects));
        return [=] {
            // Checked before the discovery (seconds to minutes): an output is no input, no database, no
            // device, FIFO or link, and the three outputs are three files.
            const io::OutputInputs inputs = discover_inputs(*paths, *db_path);
            io::check_output_paths<EmadiagError>({{*out_model, "--out-model"}, {*out_params, "--out-params"}, {*plot, "--plot"}}, inputs);
            std::vector<Run> runs;
            std::vector<std::string> labels;
            if (!tail->empty()) {
                if (db_path->empty()) throw EmadiagError("discover --tail needs --db FILE");
                if (position->empty())
                    throw EmadiagError("discover --db --tail needs --position POS: a finding belongs to one actuator, and a tail has several");
                db::Database database(*db_path);
                for (const auto& [listed, sn] : actuator_runs(database, *tail, *position, *serial, *finding_place)) {
                    runs.push_back(run_from_stored(db::load_run(database, listed.run_id)));
                    labels.push_back("run " + std::to_string(listed.run_id) + " (" + listed.started_utc + ", " +
                                     listed.sequence + ")");
                }
            } else if (!db_path->empty()) {
                throw EmadiagError("discover --db needs --tail T");
            } else if (!position->empty() || !serial->empty()) {
                throw EmadiagError("discover --position and --serial go with --db FILE --tail T");
            }
            for (const auto& p : *paths) {
                runs.push_back(read_run_csv_file(p));
                labels.push_back(io::escape_text(p));  // a file name shown in the report: printable
                if (!tail->empty()) check_run_of_actuator(runs.back(), p, *tail, *position, *serial);
            }
            if (runs.empty()) throw EmadiagError("discover: give run CSV file(s), or --db FILE --tail T");
            discovery::DiscoveryOptions opt;
            opt.max_effects = *max_effects;
            // A finding about a tail's stored runs goes into its maintenance record (open until closed).
            auto store_finding = [&](const discovery::FindingRecord& record) {
                if (tail->empty()) return;
                db::Database database(*db_path);
                db::StoredDiscoveryFinding f = *finding_place;
                f.tail_number = *tail;
                f.actuator_serial = *serial;  // every run is this actuator's (actuator_runs, check_run_of_actuator)
                f.found_utc = io::utc_now_iso8601();
                f.summary = record.summary;
                f.model_json = record.model.dump();
                const std::int64_t id = db::store_discovery_finding(database, f);
                std::cerr << "discover: finding stored as discovery finding " << id << " of " << *tail << ' ' << *position
                          << " serial " << *serial << " in " << *db_path << '\n';
            };
            if (runs.size() == 1) {
                const auto t0 = std::chrono::steady_clock::now();
                const sim::SimCounters sims0 = sim::sim_counters();
                const discovery::DiscoveryReport r = discovery::discover(runs.front(), opt);
                const sim::SimCounters sims1 = sim::sim_counters();
                const auto t1 = std::chrono::steady_clock::now();
                store_finding(discovery::finding_record(r));
                if (!out_model->empty()) write_json_file(*out_model, r.model.to_json(), inputs);
                if (!out_params->empty()) write_json_file(*out_params, r.model.params.to_json(), inputs);
                if (!plot->empty()) write_text_file(*plot, plot_of(r, labels.front()), inputs);
                if (*json) std::cout << r.to_json().dump(2) << '\n';
                else print_text(std::cout, labels.front(), r);
                if (*json) return 0;  // the JSON report stays one document
                // Where the time went.
                const auto sec = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
                const double discovery_s = sec(t0, t1);
                const double scalar_s = sims1.scalar_s - sims0.scalar_s;
                const double batch_s = sims1.batch_s - sims0.batch_s;
                const double rest_s = std::max(0.0, discovery_s - scalar_s - batch_s);
                const auto pct = [&](double v) { return " (" + fmt(discovery_s > 0 ? 100.0 * v / discovery_s : 0.0, 3) + " %)"; };
                std::cout << "\ntime: discovery " << fmt(discovery_s, 3) << " s wall: " << sims1.scalar_runs - sims0.scalar_runs
                          << " re-simulations on the scalar path " << fmt(scalar_s, 3) << " s" << pct(scalar_s) << ", "
                          << sims1.batch_runs - sims0.batch_runs << " on the batched path (" << sim::simd_target().name << ") "
                          << fmt(batch_s, 3) << " s" << pct(batch_s) << ", screening, fits and signal processing " << fmt(rest_s, 3)
                          << " s" << pct(rest_s) << '\n';
                return 0;
            }
            const discovery::AcrossRunsReport all = discovery::discover_runs(runs, labels, opt);
            const discovery::FindingRecord record = discovery::finding_record(all);
            store_finding(record);
            if (!out_model->empty()) write_json_file(*out_model, record.model, inputs);
            if (!out_params->empty()) {
                write_json_file(*out_params, all.reports.front().model.params.to_json(), inputs);
            }
            if (!plot->empty()) {
                std::size_t pick = 0;
                for (std::size_t i = 0; i < all.reports.size(); ++i) {
                    if (all.reports[i].unexplained() != nullptr) {
                        pick = i;
                        break;
                    }
                }
                write_text_file(*plot, plot_of(all.reports[pick], all.labels[pick]), inputs);
            }
            if (*json) {
                std::cout << all.to_json().dump(2) << '\n';
            } else {
                for (std::size_t i = 0; i < all.reports.size(); ++i) {
                    print_text(std::cout, all.labels[i], all.reports[i]);
                    std::cout << '\n';
                }
                std::cout << "=== across " << all.reports.size() << " runs ===\n" << all.summary();
            }
            return 0;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
