#pragma once
// One sample of a test run: the six signals of ema-reference.md section 6, each a 2 kHz period
// mean. The one shape of a run's sample in memory and in the maintenance record (core::Run's
// samples and db::StoredRun's are this type), so no layer copies it field by field.
// Header-only and in the lowest layer, because the record (maintenance_db) sits below core.
// The other shapes of a run are kept for their own jobs: sim::Sample is the simulator's output
// with its truth; discovery's RunSignals are the same signals as columns for the fits.

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
