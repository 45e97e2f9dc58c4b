#include "emadiag/db/run_store.hpp"

#include "emadiag/db/db_error.hpp"

#include "run_store_detail.hpp"

#include <sqlite3.h>

#include <cctype>
#include <cmath>
#include <map>
#include <utility>

namespace emadiag::db {

namespace {
constexpr std::size_t kMaxTailNumberLength = 16;

void check_finite(double v, const std::string& field, const std::string& context) {
    if (!std::isfinite(v)) throw DbError(context + "run field " + field + " is not a finite number (" + std::to_string(v) + ")");
}
}  // namespace

namespace detail {

std::optional<std::string> tail_number_problem(const std::string& tail_number) {
    bool ok = !tail_number.empty() && tail_number.size() <= kMaxTailNumberLength;
    for (char c : tail_number) {
        ok = ok && (std::isupper(static_cast<unsigned char>(c)) || std::isdigit(static_cast<unsigned char>(c)) || c == '-');
    }
    if (ok) return std::nullopt;
    // Quoted with control bytes escaped and at most 40 bytes long (a megabyte-long tail number gives
    // a one-line error, not a megabyte; a NUL byte does not cut the message short).
    std::string shown;
    for (std::size_t i = 0; i < tail_number.size() && i < 40; ++i) {
        const auto c = static_cast<unsigned char>(tail_number[i]);
        if (c < 0x20 || c == 0x7F) {
            static constexpr char kHex[] = "0123456789ABCDEF";
            shown += std::string("\\x") + kHex[c >> 4] + kHex[c & 15];
        } else {
            shown += static_cast<char>(c);
        }
    }
    if (tail_number.size() > 40) shown += "... (" + std::to_string(tail_number.size()) + " bytes)";
    return "tail number '" + shown + "' is not valid: use 1 to " + std::to_string(kMaxTailNumberLength) +
           " characters of A-Z, 0-9 and '-'";
}

void check_run(const StoredRun& run, const std::string& context) {
    if (const auto problem = tail_number_problem(run.tail_number)) throw DbError(context + *problem);
    // An invalid run may hold no sample (aborted before its telemetry): its raw log is its record.
    if (run.samples.empty() && run.valid) throw DbError(context + "valid run for " + run.tail_number + " has no samples");
    if (run.raw_log.empty()) {
        throw DbError(context + "run for " + run.tail_number + " has no raw log; the raw log is kept with every run");
    }
    for (const auto& [v, f] : {std::pair{run.k_t_nm_per_a, "k_t_nm_per_a"}, std::pair{run.j_kgm2, "j_kgm2"},
                               std::pair{run.tau, "tau"}, std::pair{run.sample_period_s, "sample_period_s"}}) {
        check_finite(v, f, context);
    }
    for (std::size_t i = 0; i < run.samples.size(); ++i) {
        const auto& s = run.samples[i];
        const std::string at = " of sample " + std::to_string(i);
        check_finite(s.t_s, "t_s" + at, context);
        check_finite(s.current_a, "current_a" + at, context);
        check_finite(s.speed_rad_s, "speed_rad_s" + at, context);
        check_finite(s.theta_m_rad, "theta_m_rad" + at, context);
        check_finite(s.hinge_moment_nm, "hinge_moment_nm" + at, context);
        check_finite(s.command_deg, "command_deg" + at, context);
    }
    for (const auto& e : run.estimates) {
        const std::string what = " of estimate " + e.estimator + "/" + e.parameter;
        if (e.value) check_finite(*e.value, "value" + what, context);
        check_finite(e.std_error, "std_error" + what, context);
    }
}

std::int64_t insert_run(Database& db, const StoredRun& run, std::optional<std::int64_t> session_id) {
    if (sqlite3_get_autocommit(db.handle()) != 0) {
        throw DbError("internal error: a run is written only inside an open transaction on " + db.path());
    }
    Statement(db, "INSERT OR IGNORE INTO aircraft(tail_number) VALUES (?)").bind(1, run.tail_number).run();
    Statement ins(db,
                  "INSERT INTO runs(tail_number, actuator_serial, started_utc, source, load_case, sequence, k_t_nm_per_a, "
                  "j_kgm2, tau, sample_period_s, valid, status_note, meta_json, session_id) "
                  "VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
    ins.bind(1, run.tail_number).bind(2, run.actuator_serial).bind(3, run.started_utc).bind(4, run.source);
    ins.bind(5, run.load_case).bind(6, run.sequence).bind(7, run.k_t_nm_per_a).bind(8, run.j_kgm2).bind(9, run.tau);
    ins.bind(10, run.sample_period_s).bind(11, static_cast<std::int64_t>(run.valid ? 1 : 0)).bind(12, run.status_note);
    ins.bind(13, run.meta_json);
    if (session_id) {
        ins.bind(14, *session_id);
    } else {
        ins.bind_null(14);
    }
    ins.run();
    const std::int64_t id = db.last_insert_id();

    Statement raw(db, "INSERT INTO raw_logs(run_id, format, content) VALUES (?,?,?)");
    raw.bind(1, id).bind(2, run.raw_log_format).bind_blob(3, run.raw_log).run();

    Statement smp(db, "INSERT INTO samples(run_id, sample_index, t_s, current_a, speed_rad_s, theta_m_rad, "
                      "hinge_moment_nm, command_deg) VALUES (?,?,?,?,?,?,?,?)");
    for (std::size_t i = 0; i < run.samples.size(); ++i) {
        const auto& s = run.samples[i];
        smp.bind(1, id).bind(2, static_cast<std::int64_t>(i)).bind(3, s.t_s).bind(4, s.current_a).bind(5, s.speed_rad_s);
        smp.bind(6, s.theta_m_rad).bind(7, s.hinge_moment_nm).bind(8, s.command_deg).run();
        smp.reset();
    }
    Statement est(db, "INSERT INTO estimates(run_id, estimator, parameter, value, std_error, identifiable, method, note) "
                      "VALUES (?,?,?,?,?,?,?,?)");
    for (const auto& e : run.estimates) {
        est.bind(1, id).bind(2, e.estimator).bind(3, e.parameter);
        if (e.value) {
            est.bind(4, *e.value);
        } else {
            est.bind_null(4);
        }
        est.bind(5, e.std_error).bind(6, static_cast<std::int64_t>(e.identifiable ? 1 : 0)).bind(7, e.method).bind(8, e.note);
        est.run();
        est.reset();
    }
    return id;
}

}  // namespace detail

void check_tail_number(const std::string& tail_number) {
    if (const auto problem = detail::tail_number_problem(tail_number)) throw DbError(*problem);
}

namespace {
constexpr const char* kRunColumns =
    "run_id, tail_number, actuator_serial, started_utc, source, load_case, sequence, k_t_nm_per_a, j_kgm2, tau, "
    "sample_period_s, valid, status_note, meta_json, session_id FROM runs";

StoredRun read_run_row(const Statement& st) {
    StoredRun r;
    r.run_id = st.column_int(0);
    r.tail_number = st.column_text(1);
    r.actuator_serial = st.column_text(2);
    r.started_utc = st.column_text(3);
    r.source = st.column_text(4);
    r.load_case = st.column_text(5);
    r.sequence = st.column_text(6);
    r.k_t_nm_per_a = st.column_double(7);
    r.j_kgm2 = st.column_double(8);
    r.tau = st.column_double(9);
    r.sample_period_s = st.column_double(10);
    r.valid = st.column_int(11) != 0;
    r.status_note = st.column_text(12);
    r.meta_json = st.column_text(13);
    if (!st.column_is_null(14)) r.session_id = st.column_int(14);
    return r;
}

std::vector<StoredEstimate> load_estimates(Database& db, std::int64_t run_id) {
    Statement est(db, "SELECT estimator, parameter, value, std_error, identifiable, method, note FROM estimates "
                      "WHERE run_id = ? ORDER BY estimator, parameter");
    est.bind(1, run_id);
    std::vector<StoredEstimate> out;
    while (est.step()) {
        StoredEstimate e;
        e.estimator = est.column_text(0);
        e.parameter = est.column_text(1);
        if (!est.column_is_null(2)) e.value = est.column_double(2);
        e.std_error = est.column_double(3);
        e.identifiable = est.column_int(4) != 0;
        e.method = est.column_text(5);
        e.note = est.column_text(6);
        out.push_back(e);
    }
    return out;
}
}  // namespace

StoredRun load_run(Database& db, std::int64_t run_id) {
    Statement st(db, std::string("SELECT ") + kRunColumns + " WHERE run_id = ?");
    st.bind(1, run_id);
    if (!st.step()) throw DbError("no run with id " + std::to_string(run_id) + " in " + db.path());
    StoredRun r = read_run_row(st);
    Statement smp(db, "SELECT t_s, current_a, speed_rad_s, theta_m_rad, hinge_moment_nm, command_deg FROM samples "
                      "WHERE run_id = ? ORDER BY sample_index");
    smp.bind(1, run_id);
    while (smp.step()) {
        r.samples.push_back({smp.column_double(0), smp.column_double(1), smp.column_double(2), smp.column_double(3),
                             smp.column_double(4), smp.column_double(5)});
    }
    Statement raw(db, "SELECT format, content FROM raw_logs WHERE run_id = ?");
    raw.bind(1, run_id);
    if (raw.step()) {
        r.raw_log_format = raw.column_text(0);
        r.raw_log = raw.column_text(1);
    }
    r.estimates = load_estimates(db, run_id);
    return r;
}

std::vector<StoredRun> list_runs(Database& db, const std::string& tail_number) {
    check_tail_number(tail_number);
    Statement st(db, std::string("SELECT ") + kRunColumns + " WHERE tail_number = ? ORDER BY started_utc, run_id");
    st.bind(1, tail_number);
    std::vector<StoredRun> out;
    while (st.step()) out.push_back(read_run_row(st));
    return out;
}

std::vector<StoredRun> detail::session_runs(Database& db, std::int64_t session_id) {
    Statement st(db, std::string("SELECT ") + kRunColumns + " WHERE session_id = ? ORDER BY run_id");
    st.bind(1, session_id);
    std::vector<StoredRun> out;
    while (st.step()) out.push_back(read_run_row(st));
    for (auto& r : out) r.estimates = load_estimates(db, r.run_id);
    return out;
}

std::vector<StoredRun> detail::runs_where(Database& db, const std::string& where, const std::string& value) {
    Statement st(db, "SELECT r.run_id, r.tail_number, r.actuator_serial, r.started_utc, r.source, r.load_case, r.sequence, r.k_t_nm_per_a, "
                     "r.j_kgm2, r.tau, r.sample_period_s, r.valid, r.status_note, r.meta_json, r.session_id FROM runs r "
                     "JOIN test_sessions s ON r.session_id = s.session_id WHERE " + where + " ORDER BY r.run_id");
    st.bind(1, value);
    std::vector<StoredRun> out;
    std::map<std::int64_t, std::size_t> index;
    while (st.step()) {
        out.push_back(read_run_row(st));
        index[out.back().run_id] = out.size() - 1;
    }
    if (out.empty()) return out;
    Statement est(db, "SELECT e.run_id, e.estimator, e.parameter, e.value, e.std_error, e.identifiable, e.method, e.note FROM estimates e "
                      "JOIN runs r ON e.run_id = r.run_id JOIN test_sessions s ON r.session_id = s.session_id WHERE " + where +
                      " ORDER BY e.run_id, e.estimator, e.parameter");
    est.bind(1, value);
    while (est.step()) {
        StoredEstimate e;
        e.estimator = est.column_text(1);
        e.parameter = est.column_text(2);
        if (!est.column_is_null(3)) e.value = est.column_double(3);
        e.std_error = est.column_double(4);
        e.identifiable = est.column_int(5) != 0;
        e.method = est.column_text(6);
        e.note = est.column_text(7);
        out[index.at(est.column_int(0))].estimates.push_back(std::move(e));
    }
    return out;
}

}  // namespace emadiag::db
