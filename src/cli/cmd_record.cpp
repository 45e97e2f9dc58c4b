// emadiag record: run one test sequence against the EMA on a CAN bus; write RUN.log (candump,
// every frame both ways) and RUN.csv (the run CSV format).
#include "cli/command.hpp"
#include "cli/interrupt.hpp"

#include "can_tool/recorder.hpp"
#include "can_tool/bus_sequence.hpp"
#include "core/emadiag_error.hpp"
#include "core/run_csv.hpp"
#include "emadiag/can/can_bus.hpp"
#include "emadiag/io/output_path.hpp"

#include <atomic>
#include <iostream>
#include <memory>

namespace emadiag::cli {
namespace {

constexpr int kExitInvalid = 2;
constexpr int kExitAborted = 130;

struct RecordOptions {
    std::string bus;
    std::string sequence = "dyn";
    std::string out;
    std::uint16_t session_id = 1;
    bool no_heartbeat = false;
    int answer_timeout_ms = 500;
};

const bool registered = register_command(Command{
    "record", "Run a test sequence over CAN and record RUN.log (candump) and RUN.csv",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<RecordOptions>();
        sub.add_option("--bus", o->bus, "Bus spec, e.g. socketcan:vcan0")->required();
        sub.add_option("--sequence", o->sequence, "Test sequence: dyn or brk")->capture_default_str()->check(CLI::IsMember({"dyn", "brk"}));
        sub.add_option("--out", o->out, "Output stem: writes OUT.log and OUT.csv")->required();
        sub.add_option("--session-id", o->session_id, "Session id sent with START_SEQUENCE")->capture_default_str();
        sub.add_option("--answer-timeout-ms", o->answer_timeout_ms, "Time the EMA has to answer a command")->capture_default_str();
        sub.add_flag("--no-heartbeat", o->no_heartbeat, "Test only: send no TOOL_Heartbeat (the EMA must abort)");
        return [o] {
            // Both outputs checked before the bus is touched (emadiag/io/output_path.hpp).
            io::check_output_paths<EmadiagError>({{o->out + ".log", "candump log"}, {o->out + ".csv", "run CSV"}});
            const std::atomic<bool>& interrupt = install_interrupt_handler();
            auto bus = can::open_bus(o->bus);
            can_tool::RecorderOptions ro;
            ro.sequence = can_tool::test_sequence_of(sim::parse_sequence(o->sequence));  // --sequence is dyn or brk
            ro.session_id = o->session_id;
            ro.log_path = o->out + ".log";
            ro.answer_timeout = std::chrono::milliseconds(o->answer_timeout_ms);
            ro.send_heartbeat = !o->no_heartbeat;
            can_tool::Recorder recorder(*bus, ro);
            const can_tool::RecordOutcome r = recorder.record(interrupt);
            const std::string csv = o->out + ".csv";
            write_run_csv_file(csv, r.run, io::OutputInputs({ro.log_path}));
            const auto& s = r.stats;
            std::cout << "record: " << o->sequence << " on " << o->bus << ", session " << o->session_id << ": " << r.status << '\n'
                      << "  telemetry: " << s.samples_complete << " of " << s.samples_expected << " samples complete; "
                      << s.frames_received << " of " << s.frames_expected << " frames received, " << s.frames_lost << " lost, "
                      << s.crc_failures << " CRC failures, " << s.counter_gaps << " counter gaps; loss "
                      << s.loss_fraction() * 100.0 << " % (limit " << can_tool::kMaxLossFraction * 100.0 << " %)\n"
                      << "  wrote " << r.log_lines << " frames to " << ro.log_path << " and " << r.run.samples.size() << " samples to "
                      << csv << '\n';
            if (r.status == "aborted") {
                std::cerr << "emadiag: error: run aborted (" << (interrupt.load() ? "Ctrl-C" : r.invalid_reason)
                          << "); partial log kept in " << ro.log_path << ", marked status=aborted in " << csv << '\n';
                return kExitAborted;
            }
            if (!r.valid) {
                std::cerr << "emadiag: error: run invalid: " << r.invalid_reason << " (marked valid=false in " << csv << ")\n";
                return kExitInvalid;
            }
            return 0;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
