// emadiag test-run --bus socketcan:can0 --tail N123EM [--phase pre-flight|post-flight] --db FILE
// [--model AUGMENTED.json]: the technician's one command on the ramp (diagnosis/ground_test.hpp). It prints progress, the
// findings against the limits and the verdict; the exit code is the verdict.
#include "cli/command.hpp"
#include "cli/db_source.hpp"
#include "cli/interrupt.hpp"
#include "cli/record_options.hpp"

#include "diagnosis/ground_test.hpp"
#include "estimation/health_estimate.hpp"
#include "emadiag/can/can_bus.hpp"

#include <atomic>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

namespace emadiag::cli {
namespace {

/// Exit codes: the verdict (0 serviceable), so a script or a test stand can act on it.
constexpr int kExitUnserviceable = 3;
constexpr int kExitInconclusive = 4;
constexpr int kExitNoTest = 2;
constexpr int kExitInterrupted = 130;

struct TestRunCliOptions {
    std::string bus;
    std::string tail;
    std::string phase = kPhasePreFlight;
    std::vector<std::string> sequences{"dyn", "brk"};
    std::string db = "maintenance.db";
    std::string out_dir = "test-runs";
    std::string limits;
    std::string model;
    std::uint16_t session_id = 1;
    int answer_timeout_ms = 500;
    SessionRecordInfo record;
};

std::string num(double v, int digits = 4) {
    std::ostringstream os;
    os << std::setprecision(digits) << v;
    return os.str();
}

void print_findings(std::ostream& os, const TestRunResult& r, const HealthLimits& limits) {
    os << "\nfindings (95 % intervals; limits: " << limits.source << "):\n";
    if (r.augmented_model) {
        os << "  estimated with the augmented model " << r.augmented_model->path << " (sha256 " << r.augmented_model->sha256
           << ") removed from each run: " << r.augmented_model->correction_text << '\n';
    }
    for (const auto& f : r.assessment.findings) {
        os << "  " << std::left << std::setw(7) << f.parameter << ' ' << std::setw(12) << to_string(f.estimator) << ' ';
        std::string value = "-";
        if (f.value) {
            const double se = f.std_error.value_or(0.0);
            value = num(*f.value) + " [" + num(*f.value - kZ95 * se) + ", " + num(*f.value + kZ95 * se) + "]";
        }
        os << std::setw(28) << value << std::setw(12) << (f.limit ? std::string(to_string(f.limit->kind)) + ' ' + num(f.limit->limit) : "")
           << ' ' << to_string(f.status);
        if (f.status == FindingStatus::NotIdentifiable && !f.note.empty()) os << " (" << f.note << ')';
        os << '\n';
    }
}

const bool registered = register_command(Command{
    "test-run", "The technician's test run: ground routine over CAN, estimates, verdict, stored under the tail number",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<TestRunCliOptions>();
        sub.add_option("--bus", o->bus, "Bus spec, e.g. socketcan:can0")->required();
        sub.add_option("--tail", o->tail, "Aircraft tail number (A-Z, 0-9, '-'; 1 to 16 characters)")->required();
        sub.add_option("--phase", o->phase, "pre-flight or post-flight")->capture_default_str()->check(CLI::IsMember({kPhasePreFlight, kPhasePostFlight}));
        sub.add_option("--sequences", o->sequences, "Test sequences in order (dyn: the paper's routine; brk: breakaway, for FSJ)")
            ->delimiter(',')->capture_default_str()->check(CLI::IsMember({"dyn", "brk"}));
        sub.add_option("--db", o->db, "Maintenance database (SQLite; created if missing)")->capture_default_str()->check(sqlite_path());
        sub.add_option("--out-dir", o->out_dir, "Directory for the raw bus logs and run CSVs")->capture_default_str();
        sub.add_option("--limits", o->limits, "Limits JSON (docs/test-run.md; default: the datasheet's section-8 envelope)")
            ->check(CLI::ExistingFile);
        sub.add_option("--model", o->model, "Augmented model JSON from `emadiag discover`: each run is estimated with its effects and "
                                            "terms removed (checked before anything moves; stored with its SHA-256)");
        sub.add_option("--session-id", o->session_id, "First START_SEQUENCE session id")->capture_default_str();
        add_record_options(sub, o->record);
        sub.add_option("--answer-timeout-ms", o->answer_timeout_ms, "Time the EMA has to answer a command")->capture_default_str();
        return [o] {
            const std::atomic<bool>& interrupt = install_interrupt_handler();
            TestRunOptions t;
            t.tail_number = o->tail;
            t.phase = o->phase;
            t.sequences.clear();
            for (const auto& s : o->sequences) t.sequences.push_back(parse_test_sequence(s));
            t.out_dir = o->out_dir;
            t.db_path = o->db;
            if (!o->limits.empty()) t.limits = HealthLimits::load(o->limits);
            t.augmented_model_path = o->model;
            t.first_session_id = o->session_id;
            t.answer_timeout = std::chrono::milliseconds(o->answer_timeout_ms);
            t.tool_version = EMADIAG_VERSION;
            t.record = o->record;
            t.on_progress = [](const std::string& line) { std::cout << line << '\n' << std::flush; };
            std::cout << "emadiag test-run " << EMADIAG_VERSION << ": " << t.tail_number << ", " << t.phase << ", on " << o->bus << '\n';
            auto bus = can::open_bus(o->bus);
            const TestRunResult r = run_test(*bus, t, interrupt);
            print_findings(std::cout, r, t.limits);
            std::cout << "\nVERDICT: " << to_string(r.assessment.verdict) << " -- " << r.assessment.reason << '\n'
                      << "tail " << t.tail_number << ", EMA serial " << (r.actuator_serial.empty() ? "?" : r.actuator_serial)
                      << (t.record.position.empty() ? std::string() : ", position " + t.record.position)
                      << ", test session " << r.db_session_id << " in " << t.db_path << " (" << r.started_utc << ")\n";
            if (r.installation) std::cout << "INSTALLATION CHANGE: " << describe_installation(*r.installation) << '\n';
            if (r.interrupted) return kExitInterrupted;
            if (r.assessment.verdict == Verdict::NoTest)
                std::cerr << "emadiag: test-run: NO_TEST: the EMA was not assessed (" << r.assessment.reason
                          << "); raw logs in " << t.out_dir.string() << ", session stored; run the test again\n";
            switch (r.assessment.verdict) {
                case Verdict::Serviceable: return 0;
                case Verdict::Unserviceable: return kExitUnserviceable;
                case Verdict::Inconclusive: return kExitInconclusive;
                case Verdict::NoTest: return kExitNoTest;
            }
            return kExitNoTest;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
