// Stage 7, final: the model's own parameters refitted on the trajectory when the model leaves
// structure, the residual structure of the final model, and the report's error after.
#include "discovery/stages/stages.hpp"

#include "discovery/fits/fits.hpp"
#include "discovery/screening/screen_windows.hpp"

#include <algorithm>
#include <string>

namespace emadiag::discovery::pipeline {

void final_stage(Context& ctx) {
    const RunSignals& s = ctx.signals;
    const NoiseFloor& floor = ctx.floor;
    const std::vector<char>& mask = ctx.mask;
    const sim::EmaParams& p = ctx.params;
    const RunSignals& model_sim = ctx.model_sim;
    const TrajectoryError& traj_now = ctx.traj_now;
    DiscoveryReport& rep = ctx.rep;
    // The model's own parameters refitted on the trajectory, nothing added: the torque rounds fit each
    // effect on the torque residual's windows, which can leave the trajectory well above its floor
    // with the health off its value (a library ripple: cost 16 and FDJ 1.5 se low, where the
    // trajectory's linearised refit reaches 0.9). Run when the model leaves structure the report would
    // call unexplained; kept when it removes half the excess over the floor.
    const bool effects_added = steps_added(rep);
    rep.structure = structure_reports(s, model_sim, mask, floor);
    const bool structure_left =
        std::any_of(rep.structure.begin(), rep.structure.end(), [](const StructureReport& r) { return r.significant; });
    if (effects_added && !rep.low_speed.added && structure_left) {
        try {
            const TrajectoryRefit r = refit_on_trajectory(ctx, p);
            const bool kept = r.cost < traj_now.cost - 0.5 * (traj_now.cost - 1.0);
            rep.notes.push_back("final refit of the model's own parameters on the trajectory (" + std::to_string(r.fit.simulations) +
                                " simulations): cost " + fmt3(traj_now.cost) + " -> " + fmt3(r.cost) + ", FDJ " + fmt3(p.fdj_nm) +
                                " -> " + fmt3(r.fit.params.fdj_nm) + " N m; " +
                                (kept ? "kept" : "not kept (it removes less than half the excess over the floor)"));
            if (kept) {
                adopt_trajectory_fit(ctx, r.fit);
                rep.structure = structure_reports(s, model_sim, mask, floor);
            }
        } catch (const std::exception& e) {
            rep.notes.push_back(std::string("final refit on the trajectory not possible: ") + e.what());
        }
    }
    rep.trajectory_after = traj_now;
    rep.model.error_after = model_error(s, model_sim, mask);
    rep.model.params = p;
}

}  // namespace emadiag::discovery::pipeline
