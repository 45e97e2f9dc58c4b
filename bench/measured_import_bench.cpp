// Import speed and memory of measured runs (issue 23 part 2, goal: 1 M samples/s or more from CSV).
// Writes a synthetic file of N rows in the Cranfield rig's layout (nine columns: set point, position
// error, current, profile, load, run, fault type, group, time; groups of 324 samples, the time
// restarting per group) to /tmp, imports it through the shipped map
// actuators/cranfield-linear-actuator.map.json in a child process, and prints the rows (samples) per
// second, the bytes per second, and the child's peak RSS (wait4 ru_maxrss). The file is removed.
// Usage: measured_import_bench [--rows N] (default 1 000 000). The machine is shared: run it once.
#include "emadiag/db/sha256.hpp"
#include "measured/column_map.hpp"
#include "measured/measured_import.hpp"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>

using namespace emadiag;

namespace {

constexpr std::size_t kDefaultRows = 1'000'000;
constexpr std::size_t kGroupSamples = 324;
constexpr double kRateHz = 25.0;

double cpu_seconds() {
    timespec ts{};
    ::clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// The rig's trapezoid: up 125 samples at 0.96 mm per sample, 75 at rest, down 124.
double set_point_mm(std::size_t k) {
    if (k < 125) return 20.96 + 0.96 * static_cast<double>(k);
    if (k < 200) return 20.96 + 0.96 * 124;
    return 20.96 + 0.96 * 124 - 0.96 * static_cast<double>(k - 199);
}

void write_file(const std::string& path, std::size_t rows) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (f == nullptr) {
        std::fprintf(stderr, "measured_import_bench: cannot write %s: %s\n", path.c_str(), std::strerror(errno));
        std::exit(1);
    }
    std::fputs("set_point,position_error,current,profile,load,run,fault_type,group,time\n", f);
    std::uint64_t noise = 88172645463325252ULL;  // xorshift64: a fixed sequence, no clock seed
    for (std::size_t i = 0; i < rows; ++i) {
        noise ^= noise << 13, noise ^= noise >> 7, noise ^= noise << 17;
        const double u = static_cast<double>(noise >> 11) * 0x1.0p-53;
        const std::size_t k = i % kGroupSamples, group = i / kGroupSamples + 1;
        const int load = group % 3 == 1 ? 20 : (group % 3 == 2 ? 40 : -40);
        std::fprintf(f, "%.17g,%.6f,%.17g,trap,%d,%zu,0,%zu,%.17g\n", set_point_mm(k), 2.0 * (u - 0.5), 0.38 + 0.7 * u, load,
                     (group - 1) / 5 % 10 + 1, group, static_cast<double>(k) / kRateHz);
    }
    std::fclose(f);
}

}  // namespace

int main(int argc, char** argv) {
    std::size_t rows = kDefaultRows;
    for (int i = 1; i + 1 < argc; ++i) {
        if (std::string(argv[i]) == "--rows") rows = std::strtoull(argv[i + 1], nullptr, 10);
    }
    if (rows == 0) {
        std::fprintf(stderr, "usage: measured_import_bench [--rows N] (N > 0)\n");
        return 2;
    }
    const std::string map_path = std::string(EMADIAG_SOURCE_DIR) + "/actuators/cranfield-linear-actuator.map.json";
    const std::string path = "/tmp/measured_import_bench_" + std::to_string(::getpid()) + ".csv";
    write_file(path, rows);
    const double bytes = static_cast<double>(std::filesystem::file_size(path));

    int fds[2];
    if (::pipe(fds) != 0) return 1;
    const pid_t child = ::fork();
    if (child == 0) {
        ::close(fds[0]);
        char line[512];
        try {
            const measured::ColumnMap map = measured::load_column_map(map_path);
            const auto t0 = std::chrono::steady_clock::now();
            const double cpu0_s = cpu_seconds();
            const measured::MeasuredRun run = measured::import_measured_csv(path, map);
            const double import_cpu_s = cpu_seconds() - cpu0_s;
            const double import_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            const auto t1 = std::chrono::steady_clock::now();
            const std::string hash = db::sha256_file_hex(path);
            const double hash_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
            std::snprintf(line, sizeof line, "%zu %zu %.6f %.6f %d %.6f", run.rows(), run.cycles.size(), import_s, hash_s,
                          hash == run.source_sha256 ? 1 : 0, import_cpu_s);
        } catch (const std::exception& e) {
            std::snprintf(line, sizeof line, "error %s", e.what());
        }
        const ssize_t w = ::write(fds[1], line, std::strlen(line));
        ::_exit(w > 0 ? 0 : 1);
    }
    ::close(fds[1]);
    char buf[512] = {};
    const ssize_t got = ::read(fds[0], buf, sizeof buf - 1);
    int status = 0;
    struct rusage ru {};
    ::wait4(child, &status, 0, &ru);
    std::filesystem::remove(path);
    if (got <= 0 || std::strncmp(buf, "error", 5) == 0) {
        std::fprintf(stderr, "measured_import_bench: %s\n", got > 0 ? buf : "the child gave no result");
        return 1;
    }
    std::size_t got_rows = 0, cycles = 0;
    double import_s = 0, hash_s = 0, import_cpu_s = 0;
    int hash_ok = 0;
    std::sscanf(buf, "%zu %zu %lf %lf %d %lf", &got_rows, &cycles, &import_s, &hash_s, &hash_ok, &import_cpu_s);
    std::printf("measured_import_bench: %zu rows x 9 columns (the Cranfield rig's layout), %.1f MB, map %s\n", rows, bytes / 1e6,
                map_path.c_str());
    std::printf("  imported %zu rows in %zu cycles in %.3f s: %.2f M samples/s (%.2f M fields/s, %.0f MB/s), SHA-256 included%s\n",
                got_rows, cycles, import_s, static_cast<double>(got_rows) / import_s / 1e6, 9.0 * static_cast<double>(got_rows) / import_s / 1e6,
                bytes / import_s / 1e6, hash_ok ? "" : " (HASH MISMATCH)");
    std::printf("  CPU time of the import: %.3f s: %.2f M samples per CPU second (the wall figure above shares the machine)\n",
                import_cpu_s, static_cast<double>(got_rows) / import_cpu_s / 1e6);
    std::printf("  SHA-256 of the file alone: %.3f s (%.0f MB/s)\n", hash_s, bytes / hash_s / 1e6);
    std::printf("  peak RSS of the importing process: %.1f MB (%.1f bytes per row)\n", static_cast<double>(ru.ru_maxrss) / 1024.0,
                static_cast<double>(ru.ru_maxrss) * 1024.0 / static_cast<double>(rows));
    return got_rows == rows && hash_ok ? 0 : 1;
}
