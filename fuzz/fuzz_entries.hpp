#pragma once
// One entry point per parser the fuzz targets exercise (issue 12 part 1). Each feeds one input to
// the real reader and returns when the reader accepted it or rejected it with the project's error
// (EmadiagError, CanError, SimError: a clear message naming what and where). Anything else (another
// exception, a crash, a sanitizer report, a leak) is a finding. The libFuzzer targets in this folder
// and the unit test tests/fuzz/fuzz_regression_test.cpp (the kept findings, in the normal build)
// call the same functions.
#include "emadiag/can/can_frame.hpp"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace emadiag::fuzz {

/// The DBC parser (can::parse_dbc), then encode/decode of every parsed message.
void dbc(const std::uint8_t* data, std::size_t size);
/// The candump reader (can::read_candump, the line parser under read_candump_file).
void candump(const std::uint8_t* data, std::size_t size);
/// The run CSV reader (read_run_csv).
void run_csv(const std::uint8_t* data, std::size_t size);
/// The session decoder and the recorder's sequence state machine fed one frame stream: the bytes
/// are decoded into frames (frame_stream_frames), fed to a SessionDecoder, then replayed to a
/// Recorder through a scripted bus that answers with those frames.
void frame_stream(const std::uint8_t* data, std::size_t size);
/// The model JSON loaders: network_model (NetworkModel::from_json), discovery's augmented model
/// (apply_model) and the simulator parameters (EmaParams::from_json), after the bounded JSON parse.
void model_json(const std::uint8_t* data, std::size_t size);
/// The limits JSON loader (HealthLimits::from_json after the bounded JSON parse).
void limits_json(const std::uint8_t* data, std::size_t size);
/// The dataset file reader (read_dataset on a stream).
void dataset(const std::uint8_t* data, std::size_t size);

/// Decodes fuzz bytes into a frame stream (the layout is in fuzz_entries.cpp).
[[nodiscard]] std::vector<can::CanFrame> frame_stream_frames(const std::uint8_t* data, std::size_t size);

struct Target {
    const char* name;
    void (*run)(const std::uint8_t*, std::size_t);
};
/// Every target by name ("dbc", "candump", "run_csv", "frame_stream", "model_json", "limits_json", "dataset").
[[nodiscard]] const std::vector<Target>& targets();

}  // namespace emadiag::fuzz
