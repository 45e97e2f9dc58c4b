#include "diagnosis/augmented_model_use.hpp"

#include "core/emadiag_error.hpp"
#include "discovery/model/augmented_model.hpp"
#include "discovery/model/model_correction.hpp"
#include "emadiag/db/sha256.hpp"
#include "emadiag/io/bounded_json.hpp"
#include "emadiag/sim/ema_params.hpp"

#include <fstream>
#include <sstream>

namespace emadiag {
namespace {

std::string without_prefix(const std::string& what) {
    const std::string prefix = "[emadiag] ";
    return what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what;
}

/// The model applied to datasheet parameters with the given constants, and its correction.
discovery::ModelCorrection correction_for(const nlohmann::json& j, double k_t_nm_per_a, double j_kgm2, double tau) {
    sim::EmaParams params = sim::EmaParams::datasheet();
    params.k_t_nm_per_a = k_t_nm_per_a;
    params.j_kgm2 = j_kgm2;
    params.tau = tau;
    discovery::apply_model(j, params);
    return discovery::model_correction(params);
}

nlohmann::json parse_model(const std::string& path, const std::string& text) {
    std::string error;
    const auto j = io::parse_bounded_json(text, error);
    if (!j) throw EmadiagError("--model " + path + ": " + error);
    if (!discovery::is_discovery_model(*j)) {
        throw EmadiagError("--model " + path +
                           ": not an augmented model from `emadiag discover` (it needs \"version\", \"terms\" and \"health\" or "
                           "\"base\"); test-run estimates with the shipped network models, --model only names an augmented model");
    }
    return *j;
}

}  // namespace

AugmentedModelUse augmented_model_from_text(const std::string& path, const std::string& text) {
    const nlohmann::json j = parse_model(path, text);
    AugmentedModelUse m;
    m.path = path;
    m.text = text;
    m.sha256 = db::sha256_hex(text);
    try {
        const sim::EmaParams datasheet = sim::EmaParams::datasheet();
        m.correction_text = correction_for(j, datasheet.k_t_nm_per_a, datasheet.j_kgm2, datasheet.tau).text();
    } catch (const std::exception& e) {
        throw EmadiagError("--model " + path + ": " + without_prefix(e.what()));
    }
    if (m.correction_text.empty()) m.correction_text = "nothing (the model has no effect or term)";
    return m;
}

AugmentedModelUse load_augmented_model(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw EmadiagError("--model " + path + ": cannot open the augmented model file");
    std::string text;
    char buf[65536];
    while (in.read(buf, sizeof buf) || in.gcount() > 0) {
        text.append(buf, static_cast<std::size_t>(in.gcount()));
        if (text.size() > io::kMaxJsonBytes) {
            throw EmadiagError("--model " + path + ": file exceeds the limit kMaxJsonBytes = " + std::to_string(io::kMaxJsonBytes) +
                               " bytes");
        }
    }
    if (in.bad()) throw EmadiagError("--model " + path + ": read error");
    return augmented_model_from_text(path, text);
}

RunEstimates estimate_with_augmented_model(const Run& run, const AugmentedModelUse& model) {
    const nlohmann::json j = parse_model(model.path, model.text);
    discovery::ModelCorrection c;
    try {
        c = correction_for(j, run.constants.k_t_nm_per_a, run.constants.j_kgm2, run.constants.tau);
    } catch (const std::exception& e) {
        throw EmadiagError("--model " + model.path + ": " + without_prefix(e.what()));
    }
    RunEstimates out = estimate_run(check_run(discovery::remove_model_effects(run, c)));  // the corrected run is checked as it is made
    out.model_files.insert(out.model_files.begin(), model.path);
    out.notes.insert(out.notes.begin(), "augmented model " + model.path + " (sha256 " + model.sha256 +
                                            "): removed from the run before estimation: " +
                                            (c.text().empty() ? std::string("nothing") : c.text()));
    return out;
}

}  // namespace emadiag
