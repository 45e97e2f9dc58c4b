#pragma once
// Test support: one stored run with everything a StoredRun holds (samples, a raw log with a NUL
// byte to prove it is kept byte for byte, an estimate with and one without a value); the run store
// and the test session store tests both start from it.
#include "emadiag/db/run_store.hpp"

#include <optional>
#include <string>

namespace emadiag::test {

inline db::StoredRun example_stored_run(const std::string& sequence = "dyn", const std::string& tail = "F-WEMA") {
    db::StoredRun r;
    r.tail_number = tail;
    r.actuator_serial = "SN-0042";
    r.started_utc = "2026-11-22T20:00:00Z";
    r.source = "test-run socketcan:vcan0";
    r.load_case = "A";
    r.sequence = sequence;
    r.k_t_nm_per_a = 0.2;
    r.j_kgm2 = 1.65e-4;
    r.tau = 800;
    r.sample_period_s = 5e-4;
    for (int i = 0; i < 10; ++i) r.samples.push_back({5e-4 * (i + 1), 0.1 * i, -3.0 * i, 0.01 * i, 5.0, -0.1 * i});
    r.raw_log_format = "candump";
    r.raw_log = std::string("(1.000000) vcan0 123#00\n") + '\0' + "binary-safe " + sequence;
    r.estimates.push_back({"physics", "FDJ_Nm", 0.081, 0.0004, true, "physics-wrls", ""});
    r.estimates.push_back({"physics", "eta_O", std::nullopt, 0.0, false, "physics-wrls", "not identifiable: constant load"});
    return r;
}

}  // namespace emadiag::test
