#pragma once
// Across DYN and BRK (issue 10 part 5; docs/discovery.md "Across DYN and BRK").
//
// A BRK run barely moves, so the torque residual that discovery screens is almost empty there; what a
// BRK run measures is the breakaway threshold in each direction, S_d = d (k_t I - F_R) = FSJ + c(d)|F_R|
// (estimation/breakaway.hpp), each to about 0.001 N m. Anything at rest that acts the same way in
// both directions shifts the two thresholds oppositely: half their difference, beyond what the model
// predicts, is a constant offset at rest, measured some ten times as finely as a DYN run's torque
// residual sees a constant torque (its size floor kMinEffectPeakNm is 0.005 N m).
//
// A BRK run alone cannot say what the offset is: a real torque on the shaft (a Coulomb asymmetry, a
// constant load) and a hinge-moment sensor offset move the thresholds alike, while a current sensor
// offset that the controller does not see moves them not at all. A DYN run of the same actuator can:
// each candidate, sized by the BRK asymmetry (not fitted to the DYN run), is added to the DYN run's
// model and the DYN trajectory (current, speed, angle, load in noise floors) is compared with the
// model's own, the health refitted on the trajectory for each. So the size comes from the BRK run
// and the identity from the DYN run: an effect neither run names alone.
//
// Steps, per BRK run (paired with the nearest DYN run in the order given):
//  1. the measured thresholds S_+ and S_- with their standard errors, after removing the DYN model's
//     sensor errors from the BRK run (the breakaway analysis reads the recorded current: a current
//     sensor offset of 0.1 A that the DYN run names otherwise spoils the BRK run's FSJ);
//  2. the DYN run's model (its health, found terms and effects; FSJ from the BRK run) re-simulated on
//     the BRK sequence, noise none, and analysed the same way: the model's S_+ and S_-;
//  3. the asymmetry A = ((S_+ - S_+,model) - (S_- - S_-,model)) / 2 and z = A / se(A); the BRK run
//     agrees with the model when |z| < kBrkAsymmetryMinZ;
//  4. otherwise each constant term a BRK run can see (torque, hinge moment, current, angle: a probe
//     re-simulated on the BRK sequence gives its asymmetry per unit) sized to A; when the DYN model
//     has torque terms that act at rest (no speed factor), each also in their place, sized to the
//     asymmetry beyond the model without them (the DYN run may have misnamed the offset);
//  5. each one added to the DYN model, the health refitted on the DYN trajectory: the BRK run shows
//     the offset exists, the DYN run tells the candidates apart; the best cost names it unless the
//     DYN trajectory refutes it (worse than the model's own refit beyond not_told_apart); two names
//     within not_told_apart of each other are both reported.
#include "discovery/discovery.hpp"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace emadiag::discovery {

/// |z| of the BRK asymmetry beyond the model from which a constant offset at rest is claimed.
inline constexpr double kBrkAsymmetryMinZ = 4.0;
/// The noise-free model's thresholds must average to its FSJ within this fraction.
inline constexpr double kBrkModelFsjTolerance = 0.05;
/// A candidate explains an asymmetry only if its probe moves the asymmetry by at least this many of
/// the measurement's standard errors (a current sensor offset the controller does not see moves it
/// by nothing).
inline constexpr double kBrkProbeMinZ = 3.0;

/// One candidate for a constant offset at rest, sized by the BRK asymmetry.
struct RestOffsetHypothesis {
    std::string key, text;           ///< physics_names.hpp
    sim::Term term;                  ///< coefficient from the asymmetry, std_error from its se
    double asymmetry_per_unit = 0;   ///< re-simulated BRK: asymmetry (N m) per unit of the coefficient
    double dyn_cost = 0;             ///< DYN trajectory cost with the term, health refitted on the trajectory
    TrajectoryError dyn_error;
    double fdj_nm = 0, fdj_se_nm = 0;  ///< FDJ of that refit
    std::string replaces;            ///< the DYN model's terms acting at rest it replaces (empty: added to them)
};

struct BreakawayAcross {
    std::string brk_label, dyn_label;
    std::string problem;             ///< why the comparison could not be made (empty when it was)
    double up_nm = 0, up_se_nm = 0, down_nm = 0, down_se_nm = 0;  ///< measured S_+ and S_-
    double up_model_nm = 0, down_model_nm = 0;                    ///< the DYN model's, on the BRK sequence
    double fsj_nm = 0;               ///< FSJ the model was given (the measured thresholds' mean)
    std::string sensor_correction;   ///< the DYN model's sensor errors removed from the BRK run (empty: none)
    std::string as_recorded;         ///< the thresholds of the BRK run as recorded, when a correction was made
    double asymmetry_nm = 0, asymmetry_se_nm = 0, z = 0;
    bool significant = false;        ///< |z| >= kBrkAsymmetryMinZ
    double dyn_cost_before = 0;      ///< the DYN model's own trajectory cost
    double dyn_cost_model = 0;       ///< ... with its health refitted on the trajectory (no new term)
    double fdj_before_nm = 0;        ///< the DYN run's model's FDJ (found with the offset unmodelled)
    std::vector<RestOffsetHypothesis> hypotheses;  ///< those that can explain it, best DYN cost first
    bool rejected = false;           ///< candidates examined, every one refuted by the DYN trajectory
    bool equivalent = false;         ///< the best two are not told apart by the DYN trajectory
    std::vector<sim::Term> terms;    ///< the finding: the best hypothesis's term (empty when none)
    std::string key, text, verdict;

    [[nodiscard]] nlohmann::json to_json() const;
};

/// Steps 1 to 5 for one BRK run and the DYN run (with its discovery report) it is paired with.
/// A BRK run whose breakaways are not both found gives `problem` and nothing else.
[[nodiscard]] BreakawayAcross breakaway_across(const Run& brk, const std::string& brk_label, const Run& dyn,
                                               const std::string& dyn_label, const DiscoveryReport& dyn_report);

}  // namespace emadiag::discovery
