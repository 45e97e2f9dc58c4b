#pragma once
// The record options every command that stores a session takes (test-run, import, history-sim):
// --position, --positions, --cycles, --hours, --operator, --technician, --certificate.
#include "cli/numeric_option.hpp"
#include "diagnosis/session_storage.hpp"

#include <CLI/CLI.hpp>

#include <cstdint>
#include <memory>

namespace emadiag::cli {

/// Bounds of the technical log counters (issue 21 item 14): far above any airframe's life, far
/// below where a count or a sum of them wraps.
inline constexpr std::int64_t kMaxFlightCycles = 100'000'000;
inline constexpr double kMaxFlightHours = 1e9;

inline void add_record_options(CLI::App& sub, SessionRecordInfo& r) {
    sub.add_option("--position", r.position, "Position of the actuator, e.g. LH-ELEV (docs/fleet-record.md lists the defaults)");
    sub.add_option("--positions", r.positions_file, "Positions file replacing the built-in list (default: $EMADIAG_POSITIONS)")
        ->check(CLI::ExistingFile);
    sub.add_option_function<std::int64_t>("--cycles", [&r](std::int64_t v) { r.cycles = v; }, "Aircraft flight cycles (technical log)")
        ->check(in_range<std::int64_t>(0, kMaxFlightCycles, "kMaxFlightCycles"));
    sub.add_option_function<double>("--hours", [&r](double v) { r.hours_h = v; }, "Aircraft flight hours (technical log)")
        ->check(in_range(0.0, kMaxFlightHours, "kMaxFlightHours"));
    sub.add_option("--operator", r.operator_id, "Aircraft operator (ID)");
    sub.add_option("--technician", r.technician_name, "Name of the person doing the work");
    sub.add_option("--certificate", r.technician_certificate, "Their certificate (licence) number");
}

}  // namespace emadiag::cli
