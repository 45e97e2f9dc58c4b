// Bounded memory and time on hostile sizes (issue 12 part 2; docs/limits.md). Generates each input on
// the fly into a temporary directory (large ones through a FIFO, so nothing big touches the disk),
// reads it with the real reader in a child process, and prints the outcome, the child's peak RSS
// (wait4 ru_maxrss) and the wall time:
//   - a run CSV of 10 million rows (read_run_csv_file)
//   - a 1 GB candump log (read_run_candump, streamed; read_candump_file, the in-memory replay)
//   - a DBC with 10^6 signals (parse_dbc_file), and one within the size limit with 120 000 signals
//   - JSON nested 10^5 deep, and a 100 MB JSON array (the model, limits and parameter loaders)
// Usage: input_limits_bench [--scale F] (F < 1 shrinks every input, e.g. 0.01 for a quick look).
#include "can_tool/candump_run.hpp"
#include "core/run_csv.hpp"
#include "diagnosis/health_limits.hpp"
#include "emadiag/can/candump_log.hpp"
#include "emadiag/can/dbc.hpp"
#include "emadiag/can/ema_icd.hpp"
#include "emadiag/sim/ema_params.hpp"
#include "estimation/network_model.hpp"

#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <string>
#include <thread>

namespace fs = std::filesystem;
using namespace emadiag;

namespace {

/// Writes chunks produced by `next` (returns false when done) to `path` until done or the reader
/// closes the FIFO.
void write_stream(const std::string& path, const std::function<bool(std::string&)>& next) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (f == nullptr) return;
    std::string chunk;
    while (next(chunk)) {
        if (std::fwrite(chunk.data(), 1, chunk.size(), f) != chunk.size()) break;  // reader gone (EPIPE)
        chunk.clear();
    }
    std::fclose(f);
}

struct Outcome {
    std::string result;
    double peak_mb = 0;
    double seconds = 0;
};

/// Runs `read` in a child; the child writes its one-line result to a pipe.
Outcome measure(const std::function<std::string()>& read, const std::function<void()>& feed) {
    int fds[2];
    if (::pipe(fds) != 0) std::abort();
    const auto t0 = std::chrono::steady_clock::now();
    const pid_t pid = ::fork();
    if (pid == 0) {
        ::close(fds[0]);
        std::string r;
        try {
            r = read();
        } catch (const std::exception& e) {
            r = std::string("error: ") + e.what();
        }
        const auto nl = r.find('\n');
        if (nl != std::string::npos) r = r.substr(0, nl) + " ...";
        if (r.size() > 200) r = r.substr(0, 200) + "...";
        (void)!::write(fds[1], r.data(), r.size());
        ::_exit(0);
    }
    ::close(fds[1]);
    std::thread feeder;
    if (feed) feeder = std::thread(feed);
    std::string result;
    char buf[512];
    ssize_t n;
    while ((n = ::read(fds[0], buf, sizeof buf)) > 0) result.append(buf, static_cast<std::size_t>(n));
    ::close(fds[0]);
    int status = 0;
    rusage ru{};
    ::wait4(pid, &status, 0, &ru);
    if (feeder.joinable()) feeder.join();
    Outcome o;
    o.result = WIFEXITED(status) ? result : "child died (signal " + std::to_string(WTERMSIG(status)) + ")";
    o.peak_mb = static_cast<double>(ru.ru_maxrss) / 1024.0;
    o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return o;
}

void report(const std::string& name, const std::string& size, const Outcome& o) {
    std::printf("%-44s %-12s peak RSS %7.1f MB  %6.2f s  %s\n", name.c_str(), size.c_str(), o.peak_mb, o.seconds, o.result.c_str());
    std::fflush(stdout);
}

std::string human(double bytes) {
    char b[32];
    if (bytes >= 1e9) std::snprintf(b, sizeof b, "%.2f GB", bytes / 1e9);
    else std::snprintf(b, sizeof b, "%.1f MB", bytes / 1e6);
    return b;
}

}  // namespace

int main(int argc, char** argv) {
    double scale = 1.0;
    for (int i = 1; i + 1 < argc; ++i)
        if (std::string(argv[i]) == "--scale") scale = std::atof(argv[i + 1]);
    std::signal(SIGPIPE, SIG_IGN);
    const fs::path dir = fs::temp_directory_path() / ("emadiag-limits-" + std::to_string(::getpid()));
    fs::create_directories(dir);
    auto fifo = [&](const std::string& name) {
        const std::string p = (dir / name).string();
        fs::remove(p);
        if (::mkfifo(p.c_str(), 0600) != 0) std::abort();
        return p;
    };
    std::printf("input limits bench (scale %.3g); limits in docs/limits.md\n", scale);

    {  // ---- the bench process itself, for reference
        const Outcome o = measure([] { return std::string("ok (does nothing)"); }, {});
        report("baseline: a child that reads nothing", "-", o);
    }
    {  // ---- run CSV, 10 million rows
        const long long rows = static_cast<long long>(10'000'000 * scale);
        const std::string p = fifo("rows.csv");
        double bytes = 0;
        const Outcome o = measure(
            [&] {
                const Run r = read_run_csv_file(p);
                return "ok: " + std::to_string(r.samples.size()) + " samples";
            },
            [&] {
                long long k = -1;
                write_stream(p, [&](std::string& c) {
                    if (k < 0) {
                        c = "# k_t_Nm_per_A=0.2\n# J_kgm2=1.65e-4\n# tau=800\n# sample_period_s=0.0005\n# case=B\n# sequence=dyn\n"
                            "t_s,current_A,speed_rad_s,theta_m_rad,hinge_moment_Nm,command_deg\n";
                        k = 0;
                    }
                    for (int j = 0; j < 10000 && k < rows; ++j, ++k) c += std::to_string(k) + ",1.5,-2.25,0.125,10,3\n";
                    bytes += static_cast<double>(c.size());
                    return !c.empty();
                });
            });
        report("run CSV, " + std::to_string(rows) + " rows", human(bytes) + " sent", o);
    }
    // ---- candump log, 1 GB: a session (identification, START) then telemetry
    const can::EmaIcd icd;
    const double log_bytes = 1e9 * scale;
    auto candump_feed = [&](const std::string& p, double& bytes) {
        return [&, p] {
            long long k = -1;
            write_stream(p, [&](std::string& c) {
                if (bytes >= log_bytes) return false;
                if (k < 0) {
                    can::EmaIdentification id;
                    id.k_t_nm_per_a = 0.2, id.j_kgm2 = 1.65e-4, id.tau = 800, id.sample_period_s = 0.0005;
                    for (const auto& f : icd.encode_ident(id)) c += can::format_candump_line(f, "vcan0") + "\n";
                    c += can::format_candump_line(icd.encode_command({can::icd::Command::StartSequence, can::icd::TestSequence::Dyn, 1}),
                                                  "vcan0") + "\n";
                    k = 0;
                }
                for (int j = 0; j < 5000; ++j, ++k) {
                    auto a = icd.encode_telemetry_a(static_cast<std::uint16_t>(k), static_cast<std::uint8_t>(k % 16), 1.0, 2.0);
                    auto b = icd.encode_telemetry_b(static_cast<std::uint16_t>(k), static_cast<std::uint8_t>(k % 16), 0.1, 5.0);
                    a.timestamp = b.timestamp = std::chrono::microseconds(1700000000000000LL + k * 500);
                    c += can::format_candump_line(a, "vcan0") + "\n" + can::format_candump_line(b, "vcan0") + "\n";
                }
                bytes += static_cast<double>(c.size());
                return true;
            });
        };
    };
    {
        const std::string p = fifo("session.log");
        double bytes = 0;
        const Outcome o = measure(
            [&] {
                const Run r = read_run_candump(p);
                return "ok: " + std::to_string(r.samples.size()) + " samples, status " + r.meta_value("status").value_or("?");
            },
            candump_feed(p, bytes));
        report("candump log -> Run (read_run_candump)", human(bytes) + " sent", o);
    }
    {
        const std::string p = fifo("replay.log");
        double bytes = 0;
        const Outcome o = measure(
            [&] {
                const auto recs = can::read_candump_file(p);
                return "ok: " + std::to_string(recs.size()) + " frames";
            },
            candump_feed(p, bytes));
        report("candump log -> memory (read_candump_file)", human(bytes) + " sent", o);
    }
    // ---- DBC with 10^6 signals (64 per message), and 120 000 signals within the size limit
    auto dbc_feed = [&](const std::string& p, long long signals, double& bytes) {
        return [&, p, signals] {
            long long s = 0;
            write_stream(p, [&](std::string& c) {
                if (s >= signals) return false;
                if (s == 0) c = "VERSION \"\"\nBU_: ECU\n";
                for (int j = 0; j < 64 && s < signals; ++j, ++s) {
                    if (s % 64 == 0) c += "BO_ " + std::to_string(0x80000000LL + s / 64) + " M" + std::to_string(s / 64) + ": 8 ECU\n";
                    c += " SG_ S" + std::to_string(s) + " : " + std::to_string(s % 64) + "|1@1+ (1,0) [0|1] \"\" ECU\n";
                }
                bytes += static_cast<double>(c.size());
                return true;
            });
        };
    };
    for (long long signals : {static_cast<long long>(1'000'000 * scale), static_cast<long long>(120'000 * std::min(scale * 10, 1.0))}) {
        const std::string p = fifo("big.dbc");
        double bytes = 0;
        const Outcome o = measure(
            [&] {
                const auto db = can::parse_dbc_file(p);
                return "ok: " + std::to_string(db.messages.size()) + " messages";
            },
            dbc_feed(p, signals, bytes));
        report("DBC, " + std::to_string(signals) + " signals", human(bytes) + " sent", o);
    }
    // ---- JSON nested 10^5 deep, and a 100 MB array, through each JSON loader
    const long long depth = static_cast<long long>(100'000 * std::max(scale, 0.01));
    const std::string deep = (dir / "deep.json").string();
    {
        std::ofstream out(deep);
        out << "{\"FDJ_Nm\":" << std::string(static_cast<std::size_t>(depth), '[') << std::string(static_cast<std::size_t>(depth), ']') << "}";
    }
    const std::string wide = (dir / "wide.json").string();
    {
        std::ofstream out(wide);
        out << "{\"FDJ_Nm\":[";
        const long long n = static_cast<long long>(100e6 * scale / 8);
        for (long long i = 0; i < n; ++i) out << (i ? ",1.25e-3" : "1.25e-3");
        out << "]}";
    }
    const std::pair<const char*, std::function<void(const std::string&)>> loaders[] = {
        {"network model", [](const std::string& p) { (void)NetworkModel::load(p); }},
        {"limits", [](const std::string& p) { (void)HealthLimits::load(p); }},
        {"sim params", [](const std::string& p) { (void)sim::EmaParams::from_json_file(p); }},
    };
    for (const auto& [what, load] : loaders) {
        for (const auto& [file, label] : {std::pair{deep, "JSON nested " + std::to_string(depth) + " deep"},
                                          std::pair{wide, std::string("JSON array, ") + human(static_cast<double>(fs::file_size(wide)))}}) {
            const Outcome o = measure(
                [&, f = file] {
                    load(f);
                    return std::string("ok");
                },
                {});
            report(label + " (" + what + ")", human(static_cast<double>(fs::file_size(file))), o);
        }
    }
    fs::remove_all(dir);
    return 0;
}
