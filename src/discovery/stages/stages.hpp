#pragma once
// Discovery's stages, in the order discover() (discovery.cpp) runs them on one Context
// (src/discovery/README.md has the diagram). Each reads and writes the context: the model
// (params, model_sim, traj_now, the effects and terms added) and the report.
#include "discovery/stages/context.hpp"

namespace emadiag::discovery::pipeline {

/// 1. Baseline: datasheet + the health the run identifies, re-simulated; the comparison mask, the
/// noise floor and the error before. Throws EmadiagError on too few comparison samples.
void baseline_stage(Context& ctx);
/// 2. Torque rounds: screen the torque residual (library and generated terms), fit the winner by
/// re-simulation, weigh its hypotheses on the trajectory, add it; up to options.max_effects rounds.
void torque_rounds_stage(Context& ctx);
/// 3. Efficiency or friction: an eta_O off the datasheet against a friction that follows the load.
void efficiency_stage(Context& ctx);
/// 4. Sensor: a position sensor offset or drift in the angle channel (open world only).
void sensor_stage(Context& ctx);
/// 5. Low speed: a Stribeck friction by the trajectory (or the torque rounds' one estimated again).
void low_speed_stage(Context& ctx);
/// 6. Ripple: a motor torque ripple by the trajectory, confirmed by the torque residual.
void ripple_stage(Context& ctx);
/// 7. Final refit on the trajectory and the residual structure of the final model; the report's
/// trajectory and error after, and the model's parameters.
void final_stage(Context& ctx);

}  // namespace emadiag::discovery::pipeline
