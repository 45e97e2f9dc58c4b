#pragma once
// One sample of a test run: the six signals of ema-reference.md section 6, each a 2 kHz period
// mean. The one shape of a run's sample from the simulator to the maintenance record: sim::Sample,
// core's Run samples and db::StoredRun's samples are this type, so no layer copies it field by field.
// Header-only and in the lowest layer, because the record (maintenance_db) and the simulator sit
// below core. The other shape is kept for its own job: discovery's RunSignals hold the same
// signals (and derived ones) as columns for the fits; the simulator's truth is sim::SampleTruth.

namespace emadiag {

struct RunSample {
    double t_s = 0;
    double current_a = 0;
    double speed_rad_s = 0;
    double theta_m_rad = 0;
    double hinge_moment_nm = 0;
    double command_deg = 0;
};

}  // namespace emadiag
