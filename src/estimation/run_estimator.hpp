#pragma once
// Both estimators on one run, side by side (ARCHITECTURE.md "seams"): the physics estimator always,
// the paper's network when a model applies (given, or shipped in models/ for the run's case and
// sequence). Used by `emadiag estimate` and by the technician's `emadiag test-run`.
#include "core/run.hpp"
#include "estimation/health_estimate.hpp"
#include "estimation/run_checks.hpp"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace emadiag {

struct RunEstimates {
    std::vector<HealthEstimate> estimates;  ///< physics first, then the network if a model applied
    std::vector<std::string> model_files;   ///< the network model used, if any
    std::vector<std::string> notes;         ///< e.g. why there is no network estimate
};

/// Where shipped models are looked for, in order (core/data_location.hpp): $EMADIAG_MODELS_DIR alone
/// when set, else <prefix>/share/emadiag/models of the installed binary, else the source tree's models/
/// of a binary in its build tree; never ./models. The first that exists is the one that counts.
[[nodiscard]] std::vector<std::filesystem::path> model_dirs();

/// A shipped model for the run's case and sequence, if any. Among several, the one trained on the
/// run's noise profile (its `noise` header, which simulated runs carry), else on `typical` noise:
/// measured runs are never noise-free, and a model trained without noise is over-confident on them.
/// Unreadable model files are skipped with a note.
[[nodiscard]] std::optional<std::string> shipped_model_for(const Run& run, std::vector<std::string>& notes);

/// The physics estimator and the network (`model_file`, else a shipped model; none is a note, not an
/// error) on a run checked where it entered (check_run).
[[nodiscard]] RunEstimates estimate_run(const CheckedRun& checked, const std::optional<std::string>& model_file = std::nullopt);

/// |difference| / combined standard error of the two methods for one parameter, when both have a
/// value; the methods agree when it is at most kZ95.
[[nodiscard]] std::optional<double> agreement_z(const HealthEstimate& a, const HealthEstimate& b, const std::string& parameter);

}  // namespace emadiag
