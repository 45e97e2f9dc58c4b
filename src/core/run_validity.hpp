#pragma once
// Whether a run may give a verdict (issue 21 item 2), decided here and nowhere else: only a
// complete, valid run may. The sources (run CSV, candump log, recorder) record what they saw in
// the metadata; every consumer that judges a run (import, estimate, the verdict of test-run and
// recover, the stored record's valid flag) reads run_validity().
//
// A run is NOT valid when any of these holds, and the reason says which:
//   - its metadata says valid=false (with its invalid_reason, e.g. "sequence incomplete");
//   - its metadata says status=aborted or status=incomplete;
//   - its samples end before the sequence does (sim::default_duration_s: DYN and SWEEP 0.5 s,
//     BRK 0.8 s), by more than kRunEndToleranceSamples sample periods: a truncated file;
//   - a sample holds a physically impossible value (sample_value_problem below).
// The reason lists every one of these that holds ("; "-separated), the first impossible sample only.
// The data of an invalid run is kept (import stores it with valid=false and the reason; estimate
// may print estimates with a warning), but no verdict is given: NO_TEST.
#include "core/run.hpp"

#include <cstddef>
#include <optional>
#include <string>

namespace emadiag {

/// The values of the `status` metadata key (can_tool/session_decoder.hpp writes them).
inline constexpr const char* kRunStatuses[] = {"complete", "aborted", "incomplete"};
/// The values of the `valid` metadata key.
inline constexpr const char* kRunValidValues[] = {"true", "false"};

/// A run whose last sample is more than this many sample periods before the end of its sequence is
/// truncated. One period covers the rounding of the sample times; a candump log may lose at most
/// kMaxLossFraction (0.1 %) of its frames anywhere, so its last sample is still present.
inline constexpr double kRunEndToleranceSamples = 1.5;

/// A sample value is physically impossible when its magnitude exceeds kImpossibleMargin times what
/// the EMA-REF-1 datasheet allows (ema-reference.md section 1): current I_max = 20 A, speed
/// w_max = 838 rad/s, motor angle tau x stop = 800 x 25 deg, hinge moment tau x T_max = 3200 N m
/// (the stall moment), command the +/-25 deg stops. The margin is wide on purpose: the current
/// loop chatters a little above I_max (section 7) and the sensors add noise; a value five times
/// the limit is no measurement of this actuator.
inline constexpr double kImpossibleMargin = 5.0;

struct RunValidity {
    bool valid = true;
    std::string reason;  ///< why not, in words a technician can act on; empty when valid
};

/// The one decision whether the run may give a verdict (see the top of this file).
[[nodiscard]] RunValidity run_validity(const Run& run);

/// The largest magnitude a run CSV's column may hold (kImpossibleMargin times the datasheet limit),
/// or nullopt for a column without one (t_s and extra columns).
[[nodiscard]] std::optional<double> sample_magnitude_limit(const std::string& column);
/// Nullopt when the value is possible; otherwise "current_A = 1e+308 exceeds the physical limit
/// +/-100 (5 x I_max = 20 A, ema-reference.md section 1)".
[[nodiscard]] std::optional<std::string> sample_value_problem(const std::string& column, double value);

/// Checks a metadata value that has a fixed set of values: case (A, A-ext, B), sequence (dyn, brk,
/// sweep), status and valid. Nullopt when the key has no fixed set or the value is allowed;
/// otherwise "case=Z is not one of A, A-ext, B".
[[nodiscard]] std::optional<std::string> metadata_value_problem(const std::string& key, const std::string& value);

}  // namespace emadiag
