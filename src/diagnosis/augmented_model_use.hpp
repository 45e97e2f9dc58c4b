#pragma once
// An augmented model from `emadiag discover` used by the technician's test run
// (`emadiag test-run --model AUGMENTED.json`): every valid run is estimated after the model's
// effects and terms are removed from it (discovery/model_correction.hpp, the same correction as
// `emadiag estimate --model`). The file is read, hashed and checked once, before anything moves on
// the bus; the spool keeps its text, so a recovered session is estimated with the same bytes, and
// the stored session lists the file with the SHA-256 of those bytes (artifact role "model").
#include "core/run.hpp"
#include "estimation/run_estimator.hpp"

#include <string>

namespace emadiag {

struct AugmentedModelUse {
    std::string path;             ///< as given (--model)
    std::string text;             ///< the file's bytes as read
    std::string sha256;           ///< SHA-256 of `text`, 64 lowercase hex digits
    std::string correction_text;  ///< what is removed from each run ("torque: 5e-05*w; ...")
};

/// Reads and checks an augmented model: the file exists and is readable, is bounded JSON, is a
/// discovery model (version, terms, health), apply_model accepts it and every effect can be removed
/// from the samples (backlash cannot). Throws EmadiagError "--model PATH: <reason>".
[[nodiscard]] AugmentedModelUse load_augmented_model(const std::string& path);
/// The same checks on text already read (the spool's copy); `path` names it in errors.
[[nodiscard]] AugmentedModelUse augmented_model_from_text(const std::string& path, const std::string& text);

/// estimate_run on `run` with the model's effects and terms removed first (with the run's own k_t,
/// J and tau). The model file leads `model_files` and a note says what was removed. Throws
/// EmadiagError as estimate_run does.
[[nodiscard]] RunEstimates estimate_with_augmented_model(const Run& run, const AugmentedModelUse& model);

}  // namespace emadiag
