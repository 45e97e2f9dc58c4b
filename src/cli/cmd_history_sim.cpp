// emadiag history-sim --db FILE --tail N123EM [--sessions 12] [--days-between 30] [--start-utc T]
//   [--fdj-start 0.08] [--fdj-rate-per-100d 0.004] [--fsj-start ...] [--fsj-rate-per-100d ...]
//   [--case A] [--noise typical] [--phase pre-flight] [--seed S]:
// a realistic maintenance history without a CAN bus, for demos and tests of `emadiag trend`. Each
// session is the technician's ground routine (DYN then BRK) simulated directly, with FDJ and FSJ
// drifting linearly in time; each run is estimated by both methods (estimate_run), the verdict is
// formed against the section-8 envelope (assess) and the session is stored like `emadiag test-run`
// stores it (runs with samples and their CSV as raw log, estimates, findings). The whole history is
// ONE transaction (db::SessionBatch): a session that fails, Ctrl-C, SIGTERM or kill -9 leave the
// database as it was before the command, never a partial history. Runs have source "history-sim"; their meta_json carries the true parameters
// (true_FDJ_Nm, true_FSJ_Nm, ...). Deterministic for a seed.
#include "cli/command.hpp"
#include "cli/db_source.hpp"
#include "cli/interrupt.hpp"
#include "cli/record_options.hpp"
#include "diagnosis/session_storage.hpp"

#include "core/emadiag_error.hpp"
#include "core/run_csv.hpp"
#include "core/sim_run.hpp"
#include "diagnosis/health_limits.hpp"
#include "diagnosis/ground_test.hpp"
#include "diagnosis/verdict.hpp"
#include "emadiag/db/run_store.hpp"
#include "emadiag/db/session_store.hpp"
#include "emadiag/io/text_field.hpp"
#include "emadiag/sim/simulator.hpp"
#include "estimation/health_estimate.hpp"
#include "estimation/run_estimator.hpp"
#include "prognostics/utc_time.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

namespace emadiag::cli {
namespace {

namespace pg = emadiag::prognostics;

constexpr const char* kHistorySimSource = "history-sim";
/// The finding whose FDJ each session line shows.
const EstimatorId kShownEstimator{EstimatorMethod::Physics, sim::Sequence::Dyn};
constexpr const char* kDefaultStartUtc = "2026-01-05T08:00:00Z";
constexpr int kMaxSessions = 1000;
constexpr double kMaxDaysBetween = 3650.0;
/// Rates are given per this many days.
constexpr double kRatePeriodDays = 100.0;

struct HistorySimOptions {
    std::string db;
    std::string tail;
    int sessions = 12;
    double days_between = 30.0;
    std::string start_utc = kDefaultStartUtc;
    double fdj_start_nm = sim::EmaParams::datasheet().fdj_nm;
    double fdj_rate_nm_per_100d = 0.0;
    double fsj_start_nm = sim::EmaParams::datasheet().fsj_nm;
    double fsj_rate_nm_per_100d = 0.0;
    std::string load_case = "A";
    std::string noise = "typical";
    std::string phase = kPhasePreFlight;
    std::uint64_t seed = 1;
    SessionRecordInfo record;        ///< --position etc.; --cycles is the first session's
    std::string serial;              ///< the simulated actuator's serial (default SIM-<tail>-<position>)
    double cycles_per_day = 0;       ///< flight cycles flown per day between sessions (0: no cycles recorded)
    double hours_per_cycle = 1.5;    ///< flight hours per cycle, for the hours counter
};

/// SplitMix64 (Steele, Lea & Flood 2014): distinct, well-mixed noise seeds per run from one seed.
std::uint64_t splitmix64(std::uint64_t x) {
    x += 0x9e3779b97f4a7c15ULL;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
}

std::string num(double v, int digits = 4) {
    std::ostringstream os;
    os << std::setprecision(digits) << v;
    return os.str();
}

void check(const HistorySimOptions& o) {
    if (o.sessions < 1 || o.sessions > kMaxSessions)
        throw EmadiagError("--sessions " + std::to_string(o.sessions) + " is not in [1, " + std::to_string(kMaxSessions) + "]");
    if (!(o.days_between > 0) || !(o.days_between <= kMaxDaysBetween))
        throw EmadiagError("--days-between " + num(o.days_between) + " is not in (0, " + num(kMaxDaysBetween) + "]");
    if (o.phase != kPhasePreFlight && o.phase != kPhasePostFlight)
        throw EmadiagError("--phase \"" + o.phase + "\": expected pre-flight or post-flight");
}

/// The whole plan, checked before anything is simulated or stored (issue 21 item 14): every
/// session's cycles (with overflow checks) and hours, and its true FDJ and FSJ. A plan that fails
/// at session 7 is refused before session 1, never half stored.
void check_plan(const HistorySimOptions& o) {
    const std::int64_t first_cycles = o.record.cycles.value_or(0);
    for (int i = 0; i < o.sessions; ++i) {
        const double t_days = i * o.days_between;
        const std::string where = "session " + std::to_string(i + 1) + " of " + std::to_string(o.sessions) + " (day " + num(t_days) + "): ";
        if (o.cycles_per_day > 0 || o.record.cycles) {
            const double flown = o.cycles_per_day * t_days;
            std::int64_t cycles = 0;
            if (!(flown <= static_cast<double>(kMaxFlightCycles)) ||
                __builtin_add_overflow(first_cycles, static_cast<std::int64_t>(std::llround(flown)), &cycles) || cycles > kMaxFlightCycles) {
                throw EmadiagError(where + "cycles " + std::to_string(first_cycles) + " + " + num(flown, 12) +
                                   " flown exceed the limit kMaxFlightCycles = " + std::to_string(kMaxFlightCycles) + "; nothing was stored");
            }
            const double hours = static_cast<double>(cycles) * o.hours_per_cycle;
            if (!(hours <= kMaxFlightHours)) {
                throw EmadiagError(where + "hours " + num(hours, 12) + " exceed the limit kMaxFlightHours = " + num(kMaxFlightHours, 12) +
                                   "; nothing was stored");
            }
        }
        sim::EmaParams p = sim::SimConfig{}.params;  // as the session loop builds it
        p.fdj_nm = o.fdj_start_nm + o.fdj_rate_nm_per_100d * t_days / kRatePeriodDays;
        p.fsj_nm = o.fsj_start_nm + o.fsj_rate_nm_per_100d * t_days / kRatePeriodDays;
        try {
            p.validate();
        } catch (const std::exception& e) {
            throw EmadiagError(where + "true FDJ " + num(p.fdj_nm) + " N m, FSJ " + num(p.fsj_nm) + " N m: " + e.what() +
                               "; nothing was stored");
        }
    }
}

const bool registered = register_command(Command{
    "history-sim", "Simulated maintenance history of one aircraft (ground routine per session, drifting friction) for emadiag trend",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<HistorySimOptions>();
        sub.add_option("--db", o->db, "Maintenance database (SQLite; created if missing; sessions are added)")->required()->check(sqlite_path());
        sub.add_option("--tail", o->tail, "Aircraft tail number")->required();
        sub.add_option("--sessions", o->sessions, "Number of test sessions")->capture_default_str();
        sub.add_option("--days-between", o->days_between, "Days between sessions")->capture_default_str();
        sub.add_option("--start-utc", o->start_utc, "Start of the first session (YYYY-MM-DDThh:mm:ssZ)")->capture_default_str();
        sub.add_option("--fdj-start", o->fdj_start_nm, "True FDJ at the first session, N m")->capture_default_str();
        sub.add_option("--fdj-rate-per-100d", o->fdj_rate_nm_per_100d, "True FDJ drift, N m per 100 days")->capture_default_str();
        sub.add_option("--fsj-start", o->fsj_start_nm, "True FSJ at the first session, N m")->capture_default_str();
        sub.add_option("--fsj-rate-per-100d", o->fsj_rate_nm_per_100d, "True FSJ drift, N m per 100 days")->capture_default_str();
        sub.add_option("--case", o->load_case, "Load case (A: on the ground)")->capture_default_str();
        sub.add_option("--noise", o->noise, "Noise profile: none or typical")->capture_default_str();
        sub.add_option("--phase", o->phase, "Phase of every session: pre-flight or post-flight")
            ->capture_default_str()
            ->check(CLI::IsMember({kPhasePreFlight, kPhasePostFlight}));
        sub.add_option("--seed", o->seed, "Seed of the sensor noise of every run")->capture_default_str();
        add_record_options(sub, o->record);
        sub.add_option("--serial", o->serial, "Actuator serial of the simulated EMA (default SIM-<tail>-<position>)");
        sub.add_option("--cycles-per-day", o->cycles_per_day, "Flight cycles per day; with it each session records cycles (from --cycles, "
                       "default 0) and hours")->capture_default_str();
        sub.add_option("--hours-per-cycle", o->hours_per_cycle, "Flight hours per cycle")->capture_default_str();
        return [o] {
            check(*o);
            db::check_tail_number(o->tail);
            if (!(o->cycles_per_day >= 0) || !(o->hours_per_cycle >= 0))
                throw EmadiagError("--cycles-per-day and --hours-per-cycle must be >= 0");
            check_plan(*o);
            db::StoredTestSession checked;
            set_record_info(checked, o->record);  // an unknown position is an error before anything is simulated
            const std::string serial =
                !o->serial.empty() ? o->serial : "SIM-" + o->tail + (o->record.position.empty() ? "" : "-" + o->record.position);
            io::check_text_field<EmadiagError>("--serial", serial);
            const std::int64_t first_cycles = o->record.cycles.value_or(0);
            const double start_days = pg::parse_utc_days_or_throw(o->start_utc, "--start-utc");
            const sim::LoadCase load_case = sim::parse_load_case(o->load_case);
            const sim::NoiseProfile noise = sim::parse_noise(o->noise);
            const HealthLimits limits = HealthLimits::datasheet_envelope();
            db::Database database(o->db);
            // Ctrl-C and SIGTERM only set a flag, seen between sessions: the transaction is rolled
            // back and the command says so (kill -9 leaves a hot journal SQLite rolls back).
            const std::atomic<bool>& interrupted = install_interrupt_handler();
            db::SessionBatch batch(database);
            std::vector<std::string> lines;  // printed once the history is committed
            std::cout << "emadiag history-sim: " << o->sessions << " " << o->phase << " sessions of " << o->tail << " every "
                      << num(o->days_between) << " days from " << o->start_utc << ", case " << o->load_case << ", noise " << o->noise
                      << ", seed " << o->seed << "\n" << std::flush;
            const auto nothing_stored = [&](int session, const std::string& why) {
                return EmadiagError("history-sim: " + why + " at session " + std::to_string(session) + " of " + std::to_string(o->sessions) +
                                    "; nothing was stored: a history is stored whole (one transaction) or not at all, and " + o->db +
                                    " is as it was before the command");
            };
            for (int i = 0; i < o->sessions; ++i) {
                if (interrupted.load()) throw nothing_stored(i + 1, "interrupted (SIGINT or SIGTERM)");
                const double t_days = i * o->days_between;
                const double fdj_nm = o->fdj_start_nm + o->fdj_rate_nm_per_100d * t_days / kRatePeriodDays;
                const double fsj_nm = o->fsj_start_nm + o->fsj_rate_nm_per_100d * t_days / kRatePeriodDays;
                const std::string started_utc = pg::format_utc_time(start_days + t_days);
                db::StoredTestSession s;
                SessionRecordInfo info = o->record;
                if (o->cycles_per_day > 0 || o->record.cycles) {
                    info.cycles = first_cycles + static_cast<std::int64_t>(std::llround(o->cycles_per_day * t_days));
                    info.hours_h = static_cast<double>(*info.cycles) * o->hours_per_cycle;
                }
                set_record_info(s, info);
                s.actuator_serial = serial;
                s.source = kHistorySimSource;
                s.work_performed = "simulated ground test (history-sim): DYN, BRK";
                s.tail_number = o->tail;
                s.phase = o->phase;
                s.started_utc = started_utc;
                s.tool_version = std::string(EMADIAG_VERSION) + " history-sim";
                s.limits_json = limits.to_json().dump();
                std::vector<AssessedRun> assessed;
                int k = 0;
                for (const sim::Sequence seq : {sim::Sequence::Dyn, sim::Sequence::Brk}) {
                    sim::SimConfig c;
                    c.load_case = load_case;
                    c.sequence = seq;
                    c.noise = noise;
                    c.params.fdj_nm = fdj_nm;
                    c.params.fsj_nm = fsj_nm;
                    try {
                        c.params.validate();
                    } catch (const std::exception& e) {
                        throw nothing_stored(i + 1, "session " + std::to_string(i + 1) + " (day " + num(t_days) + "): true FDJ " + num(fdj_nm) +
                                                        " N m, FSJ " + num(fsj_nm) + " N m: " + e.what());
                    }
                    c.seed = splitmix64(o->seed ^ splitmix64(static_cast<std::uint64_t>(2 * i + k++)));
                    const sim::SimResult result = sim::simulate(c);
                    Run run = make_run(c, result);
                    run.set_meta("source", kHistorySimSource);
                    run.set_meta("ema_serial_number", serial);
                    run.set_meta("tail_number", o->tail);
                    run.set_meta("phase", o->phase);
                    run.set_meta("history_sim_session", std::to_string(i + 1));
                    run.set_meta("history_sim_day", format_exact(t_days));
                    AssessedRun a = assess_run(run, seq, result.finite, result.finite ? "" : "the simulation diverged");
                    db::StoredRun stored = to_stored_run(run, o->tail, started_utc, a.estimates);
                    std::ostringstream csv;  // a simulated run's raw record is its run CSV
                    write_run_csv(csv, run);
                    stored.raw_log_format = "csv";
                    stored.raw_log = csv.str();
                    stored.valid = a.valid;
                    stored.status_note = a.valid ? "simulated" : a.invalid_reason;
                    s.runs.push_back(std::move(stored));
                    assessed.push_back(std::move(a));
                }
                const Assessment verdict = assess(assessed, limits);
                set_assessment(s, verdict);
                std::string physics_fdj = "-";
                for (const auto& f : verdict.findings)
                    if (f.parameter == kParamFdj && f.estimator == kShownEstimator && f.value)
                        physics_fdj = num(*f.value, 5) + " +/- " + num(f.std_error.value_or(0), 2);
                for (const auto& a : assessed)
                    if (a.estimates) add_model_artifacts(s, a.estimates->model_files);
                db::SessionReceipt receipt;
                try {
                    receipt = batch.add(s);
                } catch (const std::exception& e) {
                    throw nothing_stored(i + 1, e.what());
                }
                const std::int64_t id = receipt.session_id;
                if (receipt.installation) lines.push_back("  " + describe_installation(*receipt.installation));
                lines.push_back("  session " + std::to_string(id) + "  " + started_utc + (s.cycles ? "  cycles " + std::to_string(*s.cycles) : "") +
                                "  true FDJ " + num(fdj_nm, 5) + " FSJ " + num(fsj_nm, 5) + "  " + to_string(kShownEstimator) + " FDJ " + physics_fdj + "  " + s.verdict);
            }
            if (interrupted.load()) throw nothing_stored(o->sessions, "interrupted (SIGINT or SIGTERM)");
            batch.commit();  // a busy or full database: DbError says nothing was written
            for (const auto& line : lines) std::cout << line << '\n';
            std::cout << "stored " << o->sessions << " test sessions of " << o->tail << " in " << io::escape_text(o->db) << " (one transaction)\n";
            return 0;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
