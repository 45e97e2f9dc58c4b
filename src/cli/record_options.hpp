#pragma once
// The record options every command that stores a session takes (test-run, import, history-sim):
// --position, --positions, --cycles, --hours, --operator, --technician, --certificate.
#include "diagnosis/session_storage.hpp"

#include <CLI/CLI.hpp>

#include <memory>

namespace emadiag::cli {

inline void add_record_options(CLI::App& sub, SessionRecordInfo& r) {
    sub.add_option("--position", r.position, "Position of the actuator, e.g. LH-ELEV (docs/fleet-record.md lists the defaults)");
    sub.add_option("--positions", r.positions_file, "Positions file replacing the built-in list (default: $EMADIAG_POSITIONS)")
        ->check(CLI::ExistingFile);
    sub.add_option_function<std::int64_t>("--cycles", [&r](std::int64_t v) { r.cycles = v; }, "Aircraft flight cycles (technical log)");
    sub.add_option_function<double>("--hours", [&r](double v) { r.hours_h = v; }, "Aircraft flight hours (technical log)");
    sub.add_option("--operator", r.operator_id, "Aircraft operator (ID)");
    sub.add_option("--technician", r.technician_name, "Name of the person doing the work");
    sub.add_option("--certificate", r.technician_certificate, "Their certificate (licence) number");
}

}  // namespace emadiag::cli
