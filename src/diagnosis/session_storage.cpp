#include "diagnosis/session_storage.hpp"

#include <nlohmann/json.hpp>

namespace emadiag {

db::StoredRun to_stored_run(const Run& run, const std::string& tail, const std::string& started_utc,
                            const std::optional<RunEstimates>& estimates) {
    db::StoredRun s;
    s.tail_number = tail;
    s.actuator_serial = run.meta_value("ema_serial_number").value_or("");
    s.started_utc = started_utc;
    s.source = run.meta_value("source").value_or("");
    s.load_case = run.load_case;
    s.sequence = run.sequence;
    s.k_t_nm_per_a = run.constants.k_t_nm_per_a;
    s.j_kgm2 = run.constants.j_kgm2;
    s.tau = run.constants.tau;
    s.sample_period_s = run.constants.sample_period_s;
    s.valid = run.meta_value("valid").value_or("true") == "true";
    s.status_note = run.meta_value("status").value_or("");
    nlohmann::json meta = nlohmann::json::object();
    for (const auto& [k, v] : run.meta) meta[k] = v;
    s.meta_json = meta.dump();
    s.samples.reserve(run.samples.size());
    for (const auto& x : run.samples)
        s.samples.push_back({x.t_s, x.current_a, x.speed_rad_s, x.theta_m_rad, x.hinge_moment_nm, x.command_deg});
    if (estimates) {
        for (const auto& h : estimates->estimates)
            for (const auto& p : h.parameters) s.estimates.push_back({h.estimator, p.name, p.value, p.std_error, p.identifiable, p.method, p.note});
    }
    return s;
}

void set_assessment(db::StoredTestSession& session, const Assessment& assessment) {
    session.verdict = to_string(assessment.verdict);
    session.verdict_note = assessment.reason;
    session.findings.clear();
    for (const auto& f : assessment.findings) {
        db::StoredFinding d;
        d.parameter = f.parameter;
        d.estimator = f.estimator;
        d.value = f.value;
        d.std_error = f.std_error;
        if (f.limit) {
            d.limit_value = f.limit->limit;
            d.limit_kind = to_string(f.limit->kind);
        }
        d.status = to_string(f.status);
        d.note = f.note;
        session.findings.push_back(std::move(d));
    }
}

}  // namespace emadiag
