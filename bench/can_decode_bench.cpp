// Telemetry decode rate (frames/s on one core; goal >= 5 million) and the worst-case bus load of
// the ICD at 1 Mbit/s classic CAN.
#include "emadiag/can/bus_load.hpp"
#include "emadiag/can/ema_icd.hpp"

#include <benchmark/benchmark.h>

#include <cstdio>
#include <random>

namespace {

std::vector<emadiag::can::CanFrame> telemetry_frames(const emadiag::can::EmaIcd& icd, std::size_t samples) {
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<emadiag::can::CanFrame> frames;
    for (std::size_t k = 0; k < samples; ++k) {
        const auto i = static_cast<std::uint16_t>(k);
        const auto c = static_cast<std::uint8_t>(k % 16);
        frames.push_back(icd.encode_telemetry_a(i, c, 20 * u(rng), 800 * u(rng)));
        frames.push_back(icd.encode_telemetry_b(i, c, 300 * u(rng), 4000 * u(rng)));
    }
    return frames;
}

void BM_DecodeTelemetryFrames(benchmark::State& state) {
    const emadiag::can::EmaIcd icd;
    const auto frames = telemetry_frames(icd, 1024);
    double sink = 0;
    std::size_t bad = 0;
    for (auto _ : state) {
        for (std::size_t i = 0; i < frames.size(); i += 2) {
            emadiag::can::TelemetryA a;
            emadiag::can::TelemetryB b;
            bad += !icd.decode_telemetry_a(frames[i], a) || !a.crc_ok;
            bad += !icd.decode_telemetry_b(frames[i + 1], b) || !b.crc_ok;
            sink += a.current_a + a.speed_rad_s + b.theta_m_rad + b.hinge_moment_nm + a.index + b.counter;
        }
        benchmark::DoNotOptimize(sink);
    }
    if (bad != 0) state.SkipWithError("decode failed");
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * frames.size()));
    state.counters["frames_per_s"] =
        benchmark::Counter(static_cast<double>(state.iterations() * frames.size()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DecodeTelemetryFrames);

void BM_DecodeTelemetryGenericDbcPath(benchmark::State& state) {
    const emadiag::can::EmaIcd icd;
    const auto frames = telemetry_frames(icd, 1024);
    std::vector<emadiag::can::DecodedSignal> out;
    for (auto _ : state) {
        for (const auto& f : frames) {
            const auto& m = f.id == emadiag::can::icd::kTelemetryAId ? icd.telemetry_a : icd.telemetry_b;
            benchmark::DoNotOptimize(m.decode(f.data.data(), f.len, out));
        }
    }
    state.counters["frames_per_s"] =
        benchmark::Counter(static_cast<double>(state.iterations() * frames.size()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DecodeTelemetryGenericDbcPath);

}  // namespace

int main(int argc, char** argv) {
    const auto load = emadiag::can::cyclic_bus_load(emadiag::can::ema_database(), 1e6);
    std::printf("Worst-case bus load during a test, classic CAN at 1 Mbit/s (ema.dbc):\n%s\n", load.table().c_str());
    benchmark::Initialize(&argc, argv);
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
