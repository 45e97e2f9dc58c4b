// emadiag ema-sim: the simulated EMA (sim_backend/node) on a CAN bus, speaking can_dbc/ema.dbc.
#include "cli/command.hpp"
#include "cli/sim_options.hpp"

#include "emadiag/can/can_bus.hpp"
#include "emadiag/node/ema_node.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <sched.h>
#include <cstdio>
#include <iostream>
#include <memory>
#include <sstream>

namespace emadiag::cli {
namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_stop_signal(int) { g_stop.store(true); }

struct EmaSimOptions {
    std::string bus;
    double time_scale = 1.0;
    std::string refuse = "none";
    double drop_fraction = 0.0;
    double corrupt_crc_fraction = 0.0;
    std::optional<double> silent_after;
    bool ack_without_ground_test = false;
    std::uint64_t fault_seed = 1;
    std::uint32_t serial = 1001;
    std::uint64_t exit_after = 0;
    std::optional<double> idle_exit_s;
    std::uint32_t drop_burst = 0;
    double drop_burst_at = 0.5;
    double duplicate_fraction = 0.0;
    double reorder_fraction = 0.0;
    std::uint32_t fault_sequences = 0;
    int realtime_priority = 0;
};

/// With --exit-after and no --idle-exit, the node still gives up on a tool silent for this long.
constexpr double kDefaultIdleExitS = 30.0;
/// With an idle exit, how long the node waits for the first tool frame (a tool may take seconds to
/// start on a slow machine: it opens and migrates the database before it sends anything).
constexpr double kFirstToolWaitS = 60.0;
/// Keep answering this long after the last sequence, so the tool sees the final status and its LEAVE ack.
constexpr std::chrono::milliseconds kExitGrace{300};

const bool registered = register_command(Command{
    "ema-sim", "Run the simulated EMA node on a CAN bus (ICD can_dbc/ema.dbc)",
    [](CLI::App& sub) -> std::function<int()> {
        auto so = std::make_shared<SimulateOptions>();
        auto o = std::make_shared<EmaSimOptions>();
        sub.add_option("--bus", o->bus, "Bus spec, e.g. socketcan:vcan0")->required();
        add_simulation_options(sub, *so);
        sub.add_option("--time-scale", o->time_scale,
                       "Stream the 2 kHz telemetry this many times slower than real time (1 = real time)")
            ->capture_default_str();
        sub.add_option("--refuse-ground-test", o->refuse, "Fault: open interlock: none, wow (weight off wheels) or maintenance")
            ->capture_default_str();
        sub.add_option("--drop-fraction", o->drop_fraction, "Fault: fraction of telemetry frames not sent")->capture_default_str();
        sub.add_option("--corrupt-crc-fraction", o->corrupt_crc_fraction, "Fault: fraction of telemetry frames with a wrong CRC")
            ->capture_default_str();
        sub.add_option("--silent-after", o->silent_after, "Fault: stop transmitting after this fraction of a sequence");
        sub.add_flag("--ack-without-ground-test", o->ack_without_ground_test,
                     "Fault: accept ENTER_GROUND_TEST but stay in NORMAL mode (the tool must refuse to start)");
        sub.add_option("--fault-seed", o->fault_seed, "Seed of the fault draws")->capture_default_str();
        sub.add_option("--serial", o->serial, "Serial number reported in EMA_Ident")->capture_default_str();
        sub.add_option("--realtime-priority", o->realtime_priority,
                       "Run the bus loop under SCHED_FIFO at this priority (1-99; 0 = normal scheduling), as an EMA's "
                       "control loop would; needs CAP_SYS_NICE")
            ->capture_default_str()
            ->check(CLI::Range(0, 99));
        sub.add_option("--drop-burst", o->drop_burst, "Fault: drop this many consecutive telemetry frames once per sequence")
            ->capture_default_str();
        sub.add_option("--drop-burst-at", o->drop_burst_at, "Fault: where the burst starts, as a fraction of the sequence")
            ->capture_default_str()
            ->check(CLI::Range(0.0, 1.0));
        sub.add_option("--duplicate-fraction", o->duplicate_fraction, "Fault: fraction of telemetry frames sent twice")
            ->capture_default_str()
            ->check(CLI::Range(0.0, 1.0));
        sub.add_option("--reorder-fraction", o->reorder_fraction, "Fault: fraction of telemetry frames sent after the next one")
            ->capture_default_str()
            ->check(CLI::Range(0.0, 1.0));
        sub.add_option("--fault-sequences", o->fault_sequences,
                       "Faults act on the first this-many sequences only (0 = all): a transient disturbance")
            ->capture_default_str();
        sub.add_option("--exit-after", o->exit_after, "Exit after this many sequences have ended, done or aborted (0 = run until Ctrl-C)")
            ->capture_default_str();
        sub.add_option("--idle-exit", o->idle_exit_s,
                       "Exit when no tool has sent anything for this many seconds since its last frame (or for 60 s, or "
                       "this if longer, from start when no tool came); default 30 with --exit-after, else never")
            ->check(CLI::PositiveNumber);
        return [so, o] {
            node::EmaNodeConfig cfg;
            cfg.sim = config_from(*so);
            cfg.time_scale = o->time_scale;
            cfg.ident.serial_number = o->serial;
            cfg.ident.part_number = 0x45524631;  // "ERF1": EMA-REF-1
            cfg.ident.firmware_major = 1;
            cfg.faults.refuse_ground_test = node::parse_interlock(o->refuse);
            cfg.faults.drop_fraction = o->drop_fraction;
            cfg.faults.corrupt_crc_fraction = o->corrupt_crc_fraction;
            cfg.faults.silent_after_fraction = o->silent_after;
            cfg.faults.ack_without_ground_test = o->ack_without_ground_test;
            cfg.faults.seed = o->fault_seed;
            cfg.faults.drop_burst_frames = o->drop_burst;
            cfg.faults.drop_burst_at_fraction = o->drop_burst_at;
            cfg.faults.duplicate_fraction = o->duplicate_fraction;
            cfg.faults.reorder_fraction = o->reorder_fraction;
            cfg.faults.fault_sequences = o->fault_sequences;
            // 0: never exit for idleness.
            const double idle_exit_s = o->idle_exit_s ? *o->idle_exit_s : o->exit_after > 0 ? kDefaultIdleExitS : 0.0;
            auto bus = can::open_bus(o->bus);
            node::EmaNode ema(*bus, cfg);
            const auto t0 = std::chrono::steady_clock::now();
            ema.on_event = [t0](const std::string& what) {
                const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
                std::printf("[%10.1f ms] %s\n", ms, what.c_str());
                std::fflush(stdout);
            };
            struct sigaction sa {};
            sa.sa_handler = on_stop_signal;
            sigemptyset(&sa.sa_mask);
            sigaction(SIGINT, &sa, nullptr);
            sigaction(SIGTERM, &sa, nullptr);
            if (o->realtime_priority > 0) {
                sched_param sp{};
                sp.sched_priority = o->realtime_priority;
                if (::sched_setscheduler(0, SCHED_FIFO, &sp) != 0)
                    std::fprintf(stderr, "emadiag: warning: --realtime-priority %d: SCHED_FIFO refused (%s); running with normal scheduling\n",
                                 o->realtime_priority, std::strerror(errno));
            }
            std::printf("ema-sim on %s: case %s, noise %s, seed %llu, time scale %g\n", o->bus.c_str(), so->load_case.c_str(),
                        so->noise.c_str(), static_cast<unsigned long long>(so->seed), o->time_scale);
            std::fflush(stdout);
            std::string why_exit = "stopped by a signal";
            while (!g_stop.load()) {
                ema.poll(std::chrono::milliseconds(2));
                const auto& st = ema.stats();
                if (o->exit_after > 0 && st.sequences_done + st.sequences_aborted >= o->exit_after) {
                    why_exit = std::to_string(st.sequences_done + st.sequences_aborted) + " sequence(s) ended (--exit-after)";
                    const auto until = std::chrono::steady_clock::now() + kExitGrace;
                    while (std::chrono::steady_clock::now() < until && !g_stop.load()) ema.poll(std::chrono::milliseconds(2));
                    break;
                }
                if (idle_exit_s > 0) {
                    const auto idle = ema.tool_idle().value_or(std::chrono::steady_clock::now() - t0);
                    const double limit_s = ema.tool_idle() ? idle_exit_s : std::max(idle_exit_s, kFirstToolWaitS);
                    if (std::chrono::duration<double>(idle).count() > limit_s) {
                        std::ostringstream w;
                        w << (ema.tool_idle() ? "no tool frame" : "no tool heard") << " for " << limit_s << " s (--idle-exit)";
                        why_exit = w.str();
                        break;
                    }
                }
            }
            std::printf("ema-sim: exiting: %s\n", why_exit.c_str());
            const auto gaps = ema.heartbeat_gaps();
            std::printf("ema-sim: heartbeat gaps seen in GROUND_TEST: %zu, p50 %.1f ms, p99 %.1f ms, max %.1f ms (watchdog %lld ms)\n",
                        gaps.count, gaps.p50_ms, gaps.p99_ms, gaps.max_ms,
                        static_cast<long long>(can::icd::kHeartbeatTimeout.count()));
            const auto& st = ema.stats();
            std::printf("ema-sim: %llu sequences started, %llu done, %llu aborted; %llu telemetry frames sent, %llu dropped, %llu CRC corrupted, "
                        "%llu duplicated, %llu reordered; %llu transmit calls\n",
                        static_cast<unsigned long long>(st.sequences_started), static_cast<unsigned long long>(st.sequences_done),
                        static_cast<unsigned long long>(st.sequences_aborted), static_cast<unsigned long long>(st.telemetry_frames_sent),
                        static_cast<unsigned long long>(st.telemetry_frames_dropped),
                        static_cast<unsigned long long>(st.telemetry_crc_corrupted),
                        static_cast<unsigned long long>(st.telemetry_frames_duplicated),
                        static_cast<unsigned long long>(st.telemetry_frames_reordered), static_cast<unsigned long long>(st.send_calls));
            return 0;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
