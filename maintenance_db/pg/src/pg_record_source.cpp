#include "emadiag/db/db_error.hpp"
#include "emadiag/db/pg_fleet.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <charconv>
#include <limits>
#include <map>
#include <string_view>
#include <tuple>
#include <unordered_map>

namespace emadiag::db {
namespace {

using Row = PgConnection::RowView;
using PgPlaces = std::map<std::string, std::pair<std::string, std::string>>;  ///< position -> (ATA reference, description)

std::string text(const Row& r, int c) { return std::string(r.text(c)); }
std::optional<std::string> opt_text(const Row& r, int c) { return r.is_null(c) ? std::nullopt : std::optional<std::string>(r.text(c)); }
double num(const Row& r, int c) { return r.real(c); }
std::int64_t int_of(const Row& r, int c) { return r.integer(c); }
std::optional<double> opt_num(const Row& r, int c) { return r.is_null(c) ? std::nullopt : std::optional<double>(r.real(c)); }
std::optional<std::int64_t> opt_int(const Row& r, int c) { return r.is_null(c) ? std::nullopt : std::optional<std::int64_t>(r.integer(c)); }
bool boolean(const Row& r, int c) { return r.boolean(c); }

/// What a sessions query leaves out of its rows: the tail it selects by (every row's), and without
/// limits_and_links (SessionListParts) the three texts a report never shows, which stay empty as the
/// SQLite store leaves them. The positions' ATA reference and description come from the positions
/// table (a handful of rows), not from a join on every session.
struct SessionColumns {
    bool tail = true;
    bool limits_and_links = true;
};
std::string session_select(const SessionColumns& c) {
    std::string s = "s.session_id, ";
    if (c.tail) s += "s.tail_number, ";
    s += "s.actuator_serial, s.phase, s.started_utc, s.tool_version, s.verdict, s.verdict_note, s.position, s.cycles, s.hours_h, "
         "s.operator_id, s.technician_name, s.technician_certificate, s.work_performed, s.source, s.amends_session_id, "
         "s.correction_reason, s.content_sha256";
    if (c.limits_and_links) s += ", s.limits_json, s.limits_sha256, s.prev_sha256";
    return s + " FROM test_sessions s";
}

/// A row of session_select(c); `tail`: the tail every row has when c.tail is false.
StoredTestSession read_session(const Row& r, const SessionColumns& c, const std::string& tail, const PgPlaces& places) {
    StoredTestSession s;
    int i = 0;
    s.session_id = int_of(r, i++);
    s.tail_number = c.tail ? text(r, i++) : tail;
    s.actuator_serial = text(r, i++);
    s.phase = text(r, i++);
    s.started_utc = text(r, i++);
    s.tool_version = text(r, i++);
    s.verdict = text(r, i++);
    s.verdict_note = text(r, i++);
    s.position = opt_text(r, i++);
    if (s.position) {
        if (const auto it = places.find(*s.position); it != places.end()) {
            s.position_ata = it->second.first;
            s.position_description = it->second.second;
        }
    }
    s.cycles = opt_int(r, i++);
    s.hours_h = opt_num(r, i++);
    s.operator_id = text(r, i++);
    s.technician_name = text(r, i++);
    s.technician_certificate = text(r, i++);
    s.work_performed = text(r, i++);
    s.source = text(r, i++);
    s.amends_session_id = opt_int(r, i++);
    s.correction_reason = text(r, i++);
    s.content_sha256 = text(r, i++);
    if (c.limits_and_links) {
        s.limits_json = text(r, i++);
        s.limits_sha256 = text(r, i++);
        s.prev_sha256 = text(r, i++);
    }
    return s;
}

constexpr const char* kInstallationColumns =
    "installation_id, tail_number, position, from_serial, to_serial, detected_utc, cycles, hours_h, session_id FROM installations";
StoredInstallation read_installation(const Row& r) {
    StoredInstallation i;
    i.installation_id = int_of(r, 0);
    i.tail_number = text(r, 1);
    i.position = text(r, 2);
    i.from_serial = text(r, 3);
    i.to_serial = text(r, 4);
    i.detected_utc = text(r, 5);
    i.cycles = opt_int(r, 6);
    i.hours_h = opt_num(r, 7);
    i.session_id = int_of(r, 8);
    return i;
}

/// Reads the packed rows of schemas 5 and 6 (pg_schema/005_report_findings.sql, 006_report_sessions.sql):
/// a text is its length (int4, big-endian) and its bytes; a number or a bigint is a byte 0 (NULL) or 1
/// and its 8 bytes, big-endian (float8send, int8send: the stored value, bit for bit). Throws DbError
/// naming what was read and the byte where the row stops making sense.
class PackedReader {
public:
    PackedReader(std::string_view bytes, std::string what) : bytes_(bytes), what_(std::move(what)) {}
    [[nodiscard]] bool done() const { return at_ == bytes_.size(); }
    void text(std::string& out) {
        const auto n = static_cast<std::size_t>(big_endian(4, "a text's length cut short"));
        if (bytes_.size() - at_ < n) throw bad("a text longer than the row");
        out.assign(bytes_.substr(at_, n));
        at_ += n;
    }
    void text(std::optional<std::string>& out) {
        if (flag()) text(out.emplace());
    }
    void number(std::optional<double>& out) {
        if (flag()) out = std::bit_cast<double>(big_endian(8, "a float8 cut short"));
    }
    void integer(std::optional<std::int64_t>& out) {
        if (flag()) out = static_cast<std::int64_t>(big_endian(8, "an int8 cut short"));
    }
    /// Throws unless every byte was read.
    void finish() const {
        if (!done()) throw bad("bytes left over");
    }

private:
    [[nodiscard]] DbError bad(const char* what) const {
        return DbError(what_ + " (" + std::to_string(bytes_.size()) + " bytes) is damaged: " + what + " at byte " + std::to_string(at_),
                       DbErrorKind::Invalid);
    }
    std::uint64_t big_endian(std::size_t n, const char* what) {
        if (bytes_.size() - at_ < n) throw bad(what);
        std::uint64_t v = 0;
        for (std::size_t i = 0; i < n; ++i) v = (v << 8) | static_cast<unsigned char>(bytes_[at_ + i]);
        at_ += n;
        return v;
    }
    bool flag() {
        const auto f = big_endian(1, "a NULL flag cut short");
        if (f > 1) throw bad("a NULL flag neither 0 nor 1");
        return f == 1;
    }
    std::string_view bytes_;
    std::string what_;
    std::size_t at_ = 0;
};

/// The findings of one row of session_findings (schema 5), appended to `to`.
void unpack_findings(std::string_view bytes, std::int64_t session_id, const std::string& uri, std::vector<StoredFinding>& to) {
    PackedReader in(bytes, "fleet server " + uri + ": the packed findings of session " + std::to_string(session_id));
    while (!in.done()) {
        StoredFinding& f = to.emplace_back();
        in.text(f.parameter);
        in.text(f.estimator);
        in.number(f.value);
        in.number(f.std_error);
        in.number(f.limit_value);
        in.text(f.limit_kind);
        in.text(f.status);
        in.text(f.note);
    }
}

/// One row of session_rows (schema 6): the columns a report reads, without the limits text, its
/// hash and the chain link (empty, as with SessionListParts::limits_and_links false).
StoredTestSession unpack_session(const Row& r, const std::string& tail, const PgPlaces& places, const std::string& uri) {
    StoredTestSession s;
    s.session_id = int_of(r, 0);
    s.tail_number = tail;
    s.started_utc = text(r, 1);
    PackedReader in(r.text(2), "fleet server " + uri + ": the packed row of session " + std::to_string(s.session_id));
    in.text(s.actuator_serial);
    in.text(s.phase);
    in.text(s.tool_version);
    in.text(s.verdict);
    in.text(s.verdict_note);
    in.text(s.position);
    if (s.position) {
        if (const auto it = places.find(*s.position); it != places.end()) {
            s.position_ata = it->second.first;
            s.position_description = it->second.second;
        }
    }
    in.integer(s.cycles);
    in.number(s.hours_h);
    in.text(s.operator_id);
    in.text(s.technician_name);
    in.text(s.technician_certificate);
    in.text(s.work_performed);
    in.text(s.source);
    in.integer(s.amends_session_id);
    in.text(s.correction_reason);
    in.text(s.content_sha256);
    in.finish();
    return s;
}

}  // namespace

PgRecordSource::PgRecordSource(const std::string& uri) : pg_(uri) {
    const auto v = pg_.query("SELECT to_regclass('fleet_schema_version') IS NOT NULL");
    if (v.at(0).at(0) != std::optional<std::string>("t"))
        throw DbError("fleet server " + uri + " has no emadiag schema (run `emadiag fleet-server --to URI` as its owner first)",
                      DbErrorKind::Invalid);
    // One snapshot for the whole report: a sync committing meanwhile shows entirely or not at all.
    pg_.exec("BEGIN ISOLATION LEVEL REPEATABLE READ READ ONLY");
    const auto v5 = pg_.query("SELECT coalesce(max(version), 0), current_setting('client_encoding') = current_setting('server_encoding') "
                              "FROM fleet_schema_version");
    schema_version_ = std::stoi(v5.at(0).at(0).value_or("0"));
    // The packed rows hold their texts in the server's encoding; the rows of a query come in the client's.
    same_encoding_ = v5.at(0).at(1) == std::optional<std::string>("t");
}

std::vector<std::string> PgRecordSource::tail_numbers() {
    std::vector<std::string> out;
    pg_.each_row("SELECT tail_number FROM aircraft ORDER BY tail_number", {}, [&](const Row& r) { out.push_back(text(r, 0)); });
    return out;
}

namespace {
/// A PostgreSQL bigint[] literal ("{1,2,3}") of the ids of `rows`, for `= ANY($1::bigint[])`.
template <class Row, class Id>
std::string bigint_array(const std::vector<Row>& rows, Id id) {
    std::string a = "{";
    for (std::size_t i = 0; i < rows.size(); ++i) {
        if (i > 0) a += ',';
        a += std::to_string(id(rows[i]));
    }
    return a + "}";
}

/// The runs of the sessions `out` (ids in id_array, positions in index), each with its estimates: put
/// in their sessions' runs, in run_id order.
void attach_runs(PgConnection& pg, const std::string& id_array, const std::unordered_map<std::int64_t, std::size_t>& index,
                 std::vector<StoredTestSession>& out) {
    std::vector<StoredRun> runs;
    std::unordered_map<std::int64_t, std::size_t> run_index;
    pg.each_row(
        "SELECT r.run_id, r.tail_number, r.actuator_serial, r.started_utc, r.source, r.load_case, r.sequence, "
        "r.k_t_nm_per_a, r.j_kgm2, r.tau, r.sample_period_s, r.valid, r.status_note, r.meta_json, r.session_id "
        "FROM runs r WHERE r.session_id = ANY($1::bigint[]) ORDER BY r.run_id",
        {id_array}, [&](const Row& r) {
            StoredRun run;
            run.run_id = int_of(r, 0);
            run.tail_number = text(r, 1);
            run.actuator_serial = text(r, 2);
            run.started_utc = text(r, 3);
            run.source = text(r, 4);
            run.load_case = text(r, 5);
            run.sequence = text(r, 6);
            run.k_t_nm_per_a = num(r, 7);
            run.j_kgm2 = num(r, 8);
            run.tau = num(r, 9);
            run.sample_period_s = num(r, 10);
            run.valid = boolean(r, 11);
            run.status_note = text(r, 12);
            run.meta_json = text(r, 13);
            run.session_id = int_of(r, 14);
            runs.push_back(std::move(run));
            run_index[runs.back().run_id] = runs.size() - 1;
        });
    if (!runs.empty()) {
        const std::string run_array = bigint_array(runs, [](const StoredRun& r) { return r.run_id; });
        pg.each_row(
            "SELECT e.run_id, e.estimator, e.parameter, e.value, e.std_error, e.identifiable, e.method, e.note "
            "FROM estimates e WHERE e.run_id = ANY($1::bigint[]) ORDER BY e.run_id, e.estimator, e.parameter",
            {run_array}, [&](const Row& r) {
                StoredEstimate e;
                e.estimator = text(r, 1);
                e.parameter = text(r, 2);
                e.value = opt_num(r, 3);
                e.std_error = num(r, 4);
                e.identifiable = boolean(r, 5);
                e.method = text(r, 6);
                e.note = text(r, 7);
                runs[run_index.at(int_of(r, 0))].estimates.push_back(std::move(e));
            });
    }
    for (auto& run : runs) out[index.at(*run.session_id)].runs.push_back(std::move(run));
}

}  // namespace

std::vector<StoredTestSession> PgRecordSource::sessions_where(const std::string& where, const std::string& value, const SessionListParts& parts,
                                                              bool by_tail) {
    std::vector<StoredTestSession> out;
    std::unordered_map<std::int64_t, std::size_t> index;
    // The findings arrive after the sessions (in the same pipeline, or by their ids), ordered by session:
    // each goes straight to its session, one look-up per session.
    std::vector<StoredFinding>* to = nullptr;
    std::int64_t to_id = 0;
    const auto read_finding = [&](const Row& r) {
        const std::int64_t session_id = int_of(r, 0);
        if (to == nullptr || session_id != to_id) {
            const auto it = index.find(session_id);
            if (it == index.end())  // by tail: a finding whose session has another tail (the server's check refuses that)
                throw DbError("fleet server " + pg_.uri() + ": a finding of session " + std::to_string(session_id) +
                              " is not among the sessions where " + where + " ($1 = " + value + ")");
            to = &out[it->second].findings;
            to_id = session_id;
        }
        StoredFinding& f = to->emplace_back();
        f.parameter = text(r, 1);
        f.estimator = text(r, 2);
        f.value = opt_num(r, 3);
        f.std_error = opt_num(r, 4);
        f.limit_value = opt_num(r, 5);
        f.limit_kind = text(r, 6);
        f.status = text(r, 7);
        f.note = text(r, 8);
    };
    const std::string findings_sql =
        "SELECT f.session_id, f.parameter, f.estimator, f.value, f.std_error, f.limit_value, f.limit_kind, f.status, f.note FROM findings f WHERE ";
    const std::string findings_order = " ORDER BY f.session_id, f.parameter, f.estimator";
    const SessionColumns columns{!by_tail, parts.limits_and_links};
    std::vector<PgConnection::Query> queries;
    PgPlaces loaded;
    const PgPlaces* places = places_ ? &*places_ : &loaded;
    if (!places_) {  // once per snapshot: read before the sessions' rows, in the same round trip
        queries.push_back({"SELECT position, ata_reference, description FROM positions", {}, false,
                           [&](const Row& r) { loaded[text(r, 0)] = {text(r, 1), text(r, 2)}; }});
    }
    const auto keep_places = [&] {
        if (places == &loaded) places_ = std::move(loaded);
    };
    // A tail's sessions in the order of the index (tail_number, started_utc, session_id), the rows sent
    // as the scan finds them. The planner prefers a bitmap scan and a sort of the wide rows, as if the
    // tail's heap pages were read at random: they lie together (the sync groups a batch by tail) and a
    // fleet server keeps them cached (50 x 730 fleet, 5,840 sessions: 3.4 ms against 5.8 ms, and the
    // first row only after the sort). Bitmap scans are off for this one statement, in the same round trip.
    // Schema 6: the columns a report reads of each session, packed in one value (session_rows), in the
    // order of its index (tail_number, started_utc, session_id). Its rows lie in a few runs per tail (one
    // per sync batch) but the planner costs them as scattered, and with bitmap scans off it chose a
    // sequential scan of the whole table (50 x 730: 50.6 ms, against 1.9 ms for the index scan and
    // 4.7 ms for a bitmap scan and a sort): both are off for that statement.
    const bool packed_sessions = by_tail && schema_version_ >= 6 && same_encoding_ && !parts.limits_and_links;
    if (by_tail) queries.push_back({"SET LOCAL enable_bitmapscan = off", {}, false, {}});
    if (packed_sessions) queries.push_back({"SET LOCAL enable_seqscan = off", {}, false, {}});
    queries.push_back({packed_sessions ? "SELECT r.session_id, r.started_utc, r.session FROM session_rows r WHERE r.tail_number = $1 "
                                         "ORDER BY r.started_utc, r.session_id"
                                       : "SELECT " + session_select(columns) + " WHERE " + where + " ORDER BY s.started_utc, s.session_id",
                       {value}, true, [&](const Row& r) {
                           if (r.row() == 0) {
                               out.reserve(static_cast<std::size_t>(r.row_count()));
                               index.reserve(static_cast<std::size_t>(r.row_count()));
                           }
                           out.push_back(packed_sessions ? unpack_session(r, value, *places, pg_.uri()) : read_session(r, columns, value, *places));
                           index[out.back().session_id] = out.size() - 1;
                       }});
    if (by_tail) queries.push_back({"RESET enable_bitmapscan", {}, false, {}});
    if (packed_sessions) queries.push_back({"RESET enable_seqscan", {}, false, {}});
    // Both in the binary format: the numbers come as their bytes (no text to print and parse).
    if (schema_version_ >= 5 && same_encoding_ && by_tail) {
        // A tail's findings on schema 5: one row per session (session_findings), one range of its index;
        // both queries at once, as below. A session with findings added by a later statement has a
        // row for each: its findings are then put back in (parameter, estimator) order.
        std::vector<std::size_t> merged;
        queries.push_back({"SELECT p.session_id, p.findings FROM session_findings p WHERE p.tail_number = $1 ORDER BY p.session_id", {value}, true,
                           [&](const Row& r) {
                               const std::int64_t session_id = int_of(r, 0);
                               const auto it = index.find(session_id);
                               if (it == index.end())
                                   throw DbError("fleet server " + pg_.uri() + ": findings of session " + std::to_string(session_id) +
                                                 " are not among the sessions where " + where + " ($1 = " + value + ")");
                               auto& findings = out[it->second].findings;
                               if (!findings.empty()) merged.push_back(it->second);
                               unpack_findings(r.text(1), session_id, pg_.uri(), findings);
                           }});
        pg_.each_row(queries);
        keep_places();
        for (const std::size_t i : merged)
            std::sort(out[i].findings.begin(), out[i].findings.end(), [](const StoredFinding& a, const StoredFinding& b) {
                return std::tie(a.parameter, a.estimator) < std::tie(b.parameter, b.estimator);
            });
    } else if (schema_version_ >= 3 && by_tail) {
        // A tail's findings on schema 3: one range of the index (tail_number, session_id, parameter, estimator),
        // which on schemas 3 to 6 also holds every column the report reads (an index-only scan once vacuum
        // has marked the pages; schema 7 leaves them to the table: on schema 5 and later this path serves
        // only a client whose encoding differs from the server's).
        // They do not depend on the sessions' rows, so both queries go at once (pipeline mode): the
        // server looks up the findings while the sessions are read here.
        queries.push_back({findings_sql + "f.tail_number = $1" + findings_order, {value}, true, read_finding});
        pg_.each_row(queries);
        keep_places();
    } else {
        pg_.each_row(queries);
        keep_places();
        if (out.empty()) return out;
        // The rows of these sessions by their ids (index scans on each table's key), not by a join on the
        // condition: the planner's join over the whole fleet's findings is what a report cannot afford.
        // The sessions of a serial: by their tails and ids (schema 3 has no index of findings by session id alone).
        const std::string id_array = bigint_array(out, [](const StoredTestSession& s) { return s.session_id; });
        std::string findings_where = "f.session_id = ANY($1::bigint[])";
        std::vector<std::optional<std::string>> findings_params{id_array};
        if (schema_version_ >= 3) {
            std::vector<std::string> tails;
            for (const auto& s : out) tails.push_back(s.tail_number);
            std::sort(tails.begin(), tails.end());
            tails.erase(std::unique(tails.begin(), tails.end()), tails.end());
            std::string a;
            for (const auto& t : tails) {
                a += a.empty() ? "{\"" : ",\"";
                for (const char c : t) {
                    if (c == '"' || c == '\\') a += '\\';
                    a += c;
                }
                a += '"';
            }
            findings_where = "f.tail_number = ANY($2::text[]) AND f.session_id = ANY($1::bigint[])";
            findings_params = {id_array, a + "}"};
        }
        pg_.each_row({{findings_sql + findings_where + findings_order, findings_params, true, read_finding}});
    }
    if (out.empty()) return out;
    const std::string id_array = bigint_array(out, [](const StoredTestSession& s) { return s.session_id; });
    if (parts.artifacts)
        pg_.each_row(
            "SELECT a.session_id, a.role, a.name, a.sha256 FROM session_artifacts a WHERE a.session_id = ANY($1::bigint[]) "
            "ORDER BY a.session_id, a.role, a.name",
            {id_array}, [&](const Row& r) {
                out[index.at(int_of(r, 0))].artifacts.push_back({text(r, 1), text(r, 2), text(r, 3)});
            });
    if (!parts.runs) return out;
    attach_runs(pg_, id_array, index, out);
    return out;
}

std::vector<StoredTestSession> PgRecordSource::sessions_of_tail(const std::string& tail_number, const SessionListParts& parts) {
    check_tail_number(tail_number);
    return sessions_where("s.tail_number = $1", tail_number, parts, true);
}
std::vector<StoredTestSession> PgRecordSource::sessions_of_serial(const std::string& actuator_serial, const SessionListParts& parts) {
    if (actuator_serial.empty()) throw DbError("an empty actuator serial names no actuator", DbErrorKind::Invalid);
    return sessions_where("s.actuator_serial = $1", actuator_serial, parts, false);
}
bool PgRecordSource::serial_seen_elsewhere(const std::string& serial, const std::string& tail) {
    // Two probes of the index (actuator_serial, tail_number, ...) of schema 3: a tail before this one, a tail after it.
    return pg_.query("SELECT EXISTS (SELECT 1 FROM test_sessions WHERE actuator_serial = $1 AND tail_number < $2) OR "
                     "EXISTS (SELECT 1 FROM test_sessions WHERE actuator_serial = $1 AND tail_number > $2)",
                     {serial, tail})
               .at(0)
               .at(0) == std::optional<std::string>("t");
}
std::vector<StoredInstallation> PgRecordSource::installations_of_tail(const std::string& tail_number) {
    check_tail_number(tail_number);
    std::vector<StoredInstallation> out;
    pg_.each_row(std::string("SELECT ") + kInstallationColumns + " WHERE tail_number = $1 ORDER BY installation_id", {tail_number},
                 [&](const Row& r) { out.push_back(read_installation(r)); });
    return out;
}
std::vector<StoredInstallation> PgRecordSource::installations_of_serial(const std::string& serial) {
    std::vector<StoredInstallation> out;
    pg_.each_row(std::string("SELECT ") + kInstallationColumns + " WHERE to_serial = $1 OR from_serial = $1 ORDER BY installation_id", {serial},
                 [&](const Row& r) { out.push_back(read_installation(r)); });
    return out;
}
std::vector<StoredDiscoveryFinding> PgRecordSource::discovery_findings(const std::string& tail_number, bool open_only) {
    check_tail_number(tail_number);
    std::vector<StoredDiscoveryFinding> out;
    pg_.each_row(std::string("SELECT d.finding_id, d.tail_number, d.position, coalesce(p.ata_reference, ''), "
                             "coalesce(p.description, ''), d.actuator_serial, d.found_utc, d.summary, d.model_json, "
                             "d.status, d.amends_finding_id, d.tool_version, d.content_sha256 FROM discovery_findings d "
                             "LEFT JOIN positions p ON p.position = d.position WHERE d.tail_number = $1") +
                     (open_only ? " AND d.status = 'open' AND NOT EXISTS (SELECT 1 FROM discovery_findings a WHERE "
                                  "a.amends_finding_id = d.finding_id)"
                                : "") +
                     " ORDER BY d.found_utc, d.finding_id",
                 {tail_number}, [&](const Row& r) {
                     StoredDiscoveryFinding f;
                     f.finding_id = int_of(r, 0);
                     f.tail_number = text(r, 1);
                     f.position = opt_text(r, 2);
                     f.position_ata = text(r, 3);
                     f.position_description = text(r, 4);
                     f.actuator_serial = text(r, 5);
                     f.found_utc = text(r, 6);
                     f.summary = text(r, 7);
                     f.model_json = text(r, 8);
                     f.status = text(r, 9);
                     f.amends_finding_id = opt_int(r, 10);
                     f.tool_version = text(r, 11);
                     f.content_sha256 = text(r, 12);
                     out.push_back(std::move(f));
                 });
    return out;
}
std::vector<StoredPosition> PgRecordSource::positions() {
    std::vector<StoredPosition> out;
    pg_.each_row("SELECT position, ata_reference, description FROM positions ORDER BY position", {}, [&](const Row& r) {
        out.push_back({text(r, 0), text(r, 1), text(r, 2)});
    });
    return out;
}
std::vector<SeriesStats> PgRecordSource::series_stats() {
    std::vector<SeriesStats> out;
    pg_.each_row(
        "SELECT tail_number, position, actuator_serial, parameter, n, first_days, last_days, s_w, s_wt, s_wtt, "
        "s_wy, s_wty, s_wyy, n_cycles, first_cycles, last_cycles, c_w, c_wt, c_wtt, c_wy, c_wty, c_wyy, "
        "last_session_id, last_value, last_std_error, limit_kind, limit_value FROM series_stats "
        "ORDER BY tail_number, position, actuator_serial, parameter",
        {}, [&](const Row& r) {
            SeriesStats s;
            s.tail_number = text(r, 0);
            s.position = text(r, 1);
            s.actuator_serial = text(r, 2);
            s.parameter = text(r, 3);
            s.n = int_of(r, 4);
            s.first_days = num(r, 5);
            s.last_days = num(r, 6);
            s.s_w = num(r, 7);
            s.s_wt = num(r, 8);
            s.s_wtt = num(r, 9);
            s.s_wy = num(r, 10);
            s.s_wty = num(r, 11);
            s.s_wyy = num(r, 12);
            s.n_cycles = int_of(r, 13);
            s.first_cycles = opt_num(r, 14);
            s.last_cycles = opt_num(r, 15);
            s.c_w = num(r, 16);
            s.c_wt = num(r, 17);
            s.c_wtt = num(r, 18);
            s.c_wy = num(r, 19);
            s.c_wty = num(r, 20);
            s.c_wyy = num(r, 21);
            s.last_session_id = int_of(r, 22);
            s.last_value = num(r, 23);
            s.last_std_error = num(r, 24);
            s.limit_kind = text(r, 25);
            s.limit_value = opt_num(r, 26);
            out.push_back(std::move(s));
        });
    return out;
}
std::vector<PositionStatus> PgRecordSource::position_status() {
    std::vector<PositionStatus> out;
    pg_.each_row(
        "SELECT tail_number, position, actuator_serial, sessions, last_session_id, last_utc, last_verdict, "
        "last_cycles FROM position_status ORDER BY tail_number, position",
        {}, [&](const Row& r) {
            out.push_back({text(r, 0), text(r, 1), text(r, 2), int_of(r, 3), int_of(r, 4), text(r, 5), text(r, 6), opt_int(r, 7)});
        });
    return out;
}

OpenedSource open_record_source(const std::string& db) {
    OpenedSource o;
    if (is_fleet_uri(db)) {
        o.source = std::make_unique<PgRecordSource>(db);
    } else {
        // Reports only read: opened read-only, so a database on read-only media can be reported on.
        o.sqlite = std::make_unique<Database>(db, Database::kDefaultBusyTimeoutMs, true, Database::Access::ReadOnly);
        o.source = std::make_unique<SqliteRecordSource>(*o.sqlite);
    }
    return o;
}

}  // namespace emadiag::db
