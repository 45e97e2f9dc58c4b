#include "diagnosis/session_storage.hpp"

#include "core/emadiag_error.hpp"
#include "core/run_validity.hpp"
#include "diagnosis/positions.hpp"
#include "emadiag/db/sha256.hpp"
#include "emadiag/io/text_field.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

namespace emadiag {

db::StoredRun to_stored_run(const Run& run, const std::string& tail, const std::string& started_utc,
                            const std::optional<RunEstimates>& estimates) {
    db::StoredRun s;
    s.tail_number = tail;
    s.actuator_serial = run.meta_value("ema_serial_number").value_or("");
    s.started_utc = started_utc;
    s.source = run.meta_value("source").value_or("");
    // The database's text, by the one printer. A run with no case in its metadata is a log from which
    // no run could be decoded (diagnosis/session_spool.cpp): its case is unknown, stored empty.
    s.load_case = run.meta_value("case") ? sim::to_string(run.load_case) : std::string();
    s.sequence = sim::to_string(run.sequence);
    s.k_t_nm_per_a = run.constants.k_t_nm_per_a;
    s.j_kgm2 = run.constants.j_kgm2;
    s.tau = run.constants.tau;
    s.sample_period_s = run.constants.sample_period_s;
    s.valid = run_validity(run).valid;  // the callers that judge the run set valid and the note themselves
    s.status_note = run.meta_value("status").value_or("");
    nlohmann::json meta = nlohmann::json::object();
    for (const auto& [k, v] : run.meta) meta[k] = v;
    s.meta_json = meta.dump();
    s.samples = run.samples;
    if (estimates) {
        for (const auto& h : estimates->estimates)
            for (const auto& p : h.parameters) s.estimates.push_back({to_string(h.estimator), p.name, p.value, p.std_error, p.identifiable, p.method, p.note});
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
        d.estimator = to_string(f.estimator);  // the database's text, by the one printer
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

void set_record_info(db::StoredTestSession& session, const SessionRecordInfo& info) {
    // Names people type: printable UTF-8, bounded (a line break would print a forged line in a report).
    io::check_text_field<EmadiagError>("--operator", info.operator_id);
    io::check_text_field<EmadiagError>("--technician", info.technician_name);
    io::check_text_field<EmadiagError>("--certificate", info.technician_certificate);
    if (info.cycles && *info.cycles < 0) throw EmadiagError("--cycles " + std::to_string(*info.cycles) + " is negative");
    if (info.hours_h && !(std::isfinite(*info.hours_h) && *info.hours_h >= 0))
        throw EmadiagError("--hours " + std::to_string(*info.hours_h) + " is not a number of hours >= 0");
    if (!info.technician_certificate.empty() && info.technician_name.empty())
        throw EmadiagError("--certificate " + info.technician_certificate + " without --technician: the record names the person");
    if (!info.position.empty()) {
        const PositionList list = PositionList::resolve(info.positions_file);
        const Position& p = list.find(info.position);
        session.position = p.name;
        session.position_ata = p.ata;
        session.position_description = p.description;
        session.artifacts.push_back({"positions", list.source, list.sha256});
    }
    session.cycles = info.cycles;
    session.hours_h = info.hours_h;
    session.operator_id = info.operator_id;
    session.technician_name = info.technician_name;
    session.technician_certificate = info.technician_certificate;
}

void add_model_artifacts(db::StoredTestSession& session, const std::vector<std::string>& model_files) {
    for (const auto& f : model_files) {
        const bool seen = std::any_of(session.artifacts.begin(), session.artifacts.end(),
                                      [&](const db::StoredArtifact& a) { return a.role == "model" && a.name == f; });
        if (!seen) session.artifacts.push_back({"model", f, db::sha256_file_hex(f)});
    }
}

std::string describe_installation(const db::StoredInstallation& i) {
    std::string s = "installation change at " + i.position + " of " + i.tail_number + ": " +
                    (i.from_serial.empty() ? std::string("(none recorded)") : i.from_serial) + " -> " + i.to_serial + " (session " +
                    std::to_string(i.session_id) + ", " + i.detected_utc;
    if (i.cycles) s += ", " + std::to_string(*i.cycles) + " cycles";
    return s + ")";
}

}  // namespace emadiag
