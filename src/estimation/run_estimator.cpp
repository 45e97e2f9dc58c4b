#include "estimation/run_estimator.hpp"

#include "core/data_location.hpp"

#include "estimation/network_model.hpp"
#include "estimation/physics_estimator.hpp"
#include "estimation/run_checks.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace emadiag {

std::vector<std::filesystem::path> model_dirs() {
    std::vector<std::filesystem::path> dirs;
    for (const auto& l : models_locations()) dirs.push_back(l.dir);
    return dirs;
}

std::optional<std::string> shipped_model_for(const Run& run, std::vector<std::string>& notes) {
    const std::string wanted_noise = run.meta_value("noise").value_or("typical");
    for (const auto& dir : model_dirs()) {
        std::error_code ec;
        if (!std::filesystem::is_directory(dir, ec)) continue;
        std::vector<std::filesystem::path> files;
        for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
            if (entry.path().extension() == ".json") files.push_back(entry.path());
        }
        std::sort(files.begin(), files.end());
        std::optional<std::string> first_match;
        for (const auto& f : files) {
            try {
                const NetworkModel m = NetworkModel::load(f.string());
                if (m.spec.load_case != run.load_case || m.spec.sequence != run.sequence) continue;
                if (!first_match) first_match = f.string();
                if (m.training.is_object() && m.training.value("noise", std::string{}) == wanted_noise) return f.string();
            } catch (const std::exception& e) {
                notes.push_back("skipped " + f.string() + ": " + e.what());
            }
        }
        return first_match;  // the first models/ directory found is the one that counts
    }
    return std::nullopt;
}

RunEstimates estimate_run(const CheckedRun& checked, const std::optional<std::string>& model_file) {
    const Run& run = checked.run();
    RunEstimates out;
    out.estimates.push_back(estimate_physics(checked));
    std::optional<std::string> mfile = model_file;
    if (!mfile) mfile = shipped_model_for(run, out.notes);
    if (mfile) {
        const NetworkModel m = NetworkModel::load(*mfile);
        out.estimates.push_back(m.estimate(run));
        out.model_files.push_back(*mfile);
    } else {
        out.notes.push_back("no network model for case " + sim::to_string(run.load_case) + ", sequence " + sim::to_string(run.sequence) +
                            " (give --model FILE); physics estimator only");
    }
    return out;
}

std::optional<double> agreement_z(const HealthEstimate& a, const HealthEstimate& b, const std::string& parameter) {
    const auto* p = a.find(parameter);
    const auto* q = b.find(parameter);
    if (!p || !q || !p->value || !q->value) return std::nullopt;
    const double se = std::hypot(p->std_error, q->std_error);
    return se > 0 ? std::abs(*p->value - *q->value) / se : 0.0;
}

}  // namespace emadiag
