#include "emadiag/db/session_store.hpp"

#include "emadiag/db/db_error.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/sha256.hpp"

#include "record_detail.hpp"
#include "run_store_detail.hpp"
#include "session_store_detail.hpp"

#include <algorithm>
#include <map>

namespace emadiag::db {
using namespace detail;

void detail::bind_optional(Statement& st, int index, const std::optional<double>& v) {
    if (v) {
        st.bind(index, *v);
    } else {
        st.bind_null(index);
    }
}
void detail::bind_optional(Statement& st, int index, const std::optional<std::int64_t>& v) {
    if (v) {
        st.bind(index, *v);
    } else {
        st.bind_null(index);
    }
}

namespace {
/// The statement in `slot` reset and unbound, prepared (or taken from the connection's cache) the
/// first time.
Statement& prepared(Database& db, Statement*& slot, const char* sql) {
    if (slot == nullptr) {
        slot = &db.cached(sql);
    } else {
        slot->reset();
    }
    return *slot;
}

const std::string& limits_sha256_of(Batch& b, const std::string& limits_json) {
    if (b.limits_sha256.empty() || b.limits_json != limits_json) {
        b.limits_json = limits_json;
        b.limits_sha256 = sha256_hex(limits_json);
    }
    return b.limits_sha256;
}

/// Throws DbError (kind BrokenChain) naming the tail and the session when the tail's chain head is
/// not what the tool left: the session it names is missing, of another tail, has another hash, or
/// no longer hashes to its stored value (its content was changed or damaged). One session's reads:
/// the bulk store checks this for every tail it appends to; a single store verifies the whole chain
/// first (verify_tail).
void check_chain_head(Database& db, const std::string& tail, const std::optional<std::pair<std::int64_t, std::string>>& head) {
    const auto broken = [&](const std::string& what) {
        throw DbError("tail " + tail + ": its hash chain is broken: " + what + "; nothing was stored (`emadiag verify --tail " + tail +
                          "` lists every problem; restore the database from a backup)",
                      DbErrorKind::BrokenChain);
    };
    if (!head || head->second.empty()) {
        Statement& any = db.cached("SELECT session_id FROM test_sessions WHERE tail_number = ? LIMIT 1");
        any.bind(1, tail);
        const bool has = any.step();
        const std::int64_t id = has ? any.column_int(0) : 0;
        any.reset();
        if (has) broken("it has sessions (e.g. session " + std::to_string(id) + ") but its chain head records none");
        return;
    }
    Statement& st = db.cached("SELECT tail_number, content_sha256 FROM test_sessions WHERE session_id = ?");
    st.bind(1, head->first);
    const bool found = st.step();
    const std::string of_tail = found ? st.column_text(0) : "", sha = found ? st.column_text(1) : "";
    st.reset();
    const std::string id = std::to_string(head->first);
    if (!found) broken("its chain head names session " + id + ", which is not in the database (removed outside the tool)");
    if (of_tail != tail) broken("its chain head names session " + id + ", which is a session of tail " + of_tail);
    if (sha != head->second)
        broken("session " + id + " (its newest) has hash " + sha.substr(0, 16) + "..., its chain head records " + head->second.substr(0, 16) + "...");
    const StoredTestSession s = load_session(db, head->first, FindingsLayout::ByTail);
    if (session_content_sha256(s, s.prev_sha256) != s.content_sha256)
        broken("session " + id + " (" + s.started_utc + "): its content differs from its stored hash (changed or damaged outside the tool)");
}
}  // namespace

namespace {
std::string chain_head(Database& db, Batch& b, const std::string& tail) {
    if (const auto it = b.heads.find(tail); it != b.heads.end()) return it->second.sha;
    if (const auto it = b.head_before.find(tail); it != b.head_before.end()) return it->second;
    Statement& st = db.cached("SELECT session_id, content_sha256 FROM chain_heads WHERE tail_number = ?");
    st.bind(1, tail);
    std::optional<std::pair<std::int64_t, std::string>> row;
    if (st.step()) row.emplace(st.column_int(0), st.column_text(1));
    st.reset();
    // The sealing of the version-3 migration builds the chain from nothing: no head to check.
    if (b.check_heads) check_chain_head(db, tail, row);
    const std::string head = row ? row->second : "";
    b.head_before[tail] = head;
    return head;
}

void set_chain_head(Batch& b, const std::string& tail, std::int64_t session_id, const std::string& sha) {
    Batch::Head& h = b.heads[tail];
    h.session_id = session_id;
    h.sha = sha;
    ++h.added;
}

void register_position(Database& db, Batch& b, const StoredTestSession& s) {
    std::string ata;
    if (const auto it = b.position_ata.find(*s.position); it != b.position_ata.end()) {
        ata = it->second;
    } else {
        Statement& st = db.cached("SELECT ata_reference FROM positions WHERE position = ?");
        st.bind(1, *s.position);
        const bool known = st.step();
        ata = known ? st.column_text(0) : s.position_ata;
        st.reset();
        if (!known)
            db.cached("INSERT INTO positions(position, ata_reference, description) VALUES (?,?,?)")
                .bind(1, *s.position)
                .bind(2, s.position_ata)
                .bind(3, s.position_description)
                .run();
        b.position_ata[*s.position] = ata;
    }
    if (ata != s.position_ata)
        invalid("position " + *s.position + " is recorded in " + db.path() + " with ATA reference " + ata + ", not " + s.position_ata +
                ": a position keeps its ATA reference");
}

/// Writes one checked session inside the caller's open transaction.
SessionReceipt insert_session(Database& db, Batch& b, const StoredTestSession& session) {
    // The session as given, with its three hashes beside it (no copy of the session).
    const StoredTestSession& s = session;
    const std::string& limits_sha256 = limits_sha256_of(b, s.limits_json);
    if (b.tails_known.emplace(s.tail_number, true).second)
        prepared(db, b.insert_aircraft, "INSERT OR IGNORE INTO aircraft(tail_number) VALUES (?)").bind(1, s.tail_number).run();
    if (s.position) register_position(db, b, s);
    std::optional<StoredTestSession> amended;
    if (s.amends_session_id) {
        Statement st(db, std::string("SELECT ") + kSessionColumns + " WHERE s.session_id = ?");
        st.bind(1, *s.amends_session_id);
        if (!st.step()) invalid("test session: amends session " + std::to_string(*s.amends_session_id) + ", which is not in " + db.path());
        amended = read_session_row(st);
        if (amended->tail_number != s.tail_number)
            invalid("test session: amends session " + std::to_string(*s.amends_session_id) + " of tail " + amended->tail_number +
                    ", not of " + s.tail_number);
        Statement again(db, "SELECT session_id FROM test_sessions WHERE amends_session_id = ?");
        again.bind(1, *s.amends_session_id);
        if (again.step())
            invalid("test session: session " + std::to_string(*s.amends_session_id) + " is already amended by session " +
                    std::to_string(again.column_int(0)) + "; amend that one instead");
        amended->findings = load_findings(db, amended->session_id);
    }
    const std::string prev_sha256 = chain_head(db, b, s.tail_number);
    const std::string content = content_sha256(s, limits_sha256, prev_sha256);
    if (b.next_session_id == 0) {
        // session_id is no rowid (schema/006): the next id above every one used so far, including a
        // tail's last session recorded in chain_heads (an id is never given twice).
        Statement& next = db.cached(
            "SELECT max(coalesce((SELECT max(session_id) FROM test_sessions), 0), coalesce((SELECT max(session_id) FROM chain_heads), 0)) + 1");
        next.step();
        b.next_session_id = next.column_int(0);
        next.reset();
    }
    const std::int64_t session_id = b.next_session_id++;

    // The texts are bound without a copy (bind_view): the session, the batch's limits hash and the
    // two local hashes outlive the statement's run below.
    Statement& ins = prepared(db, b.insert_session,
        "INSERT INTO test_sessions(tail_number, actuator_serial, phase, started_utc, tool_version, verdict, verdict_note, limits_json, "
        "position, cycles, hours_h, operator_id, technician_name, technician_certificate, work_performed, source, limits_sha256, "
        "amends_session_id, correction_reason, prev_sha256, content_sha256, session_id) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
    ins.bind_view(1, s.tail_number).bind_view(2, s.actuator_serial).bind_view(3, s.phase).bind_view(4, s.started_utc);
    ins.bind_view(5, s.tool_version).bind_view(6, s.verdict).bind_view(7, s.verdict_note).bind_view(8, s.limits_json);
    if (s.position) {
        ins.bind_view(9, *s.position);
    } else {
        ins.bind_null(9);
    }
    bind_optional(ins, 10, s.cycles);
    bind_optional(ins, 11, s.hours_h);
    ins.bind_view(12, s.operator_id).bind_view(13, s.technician_name).bind_view(14, s.technician_certificate).bind_view(15, s.work_performed);
    ins.bind_view(16, s.source).bind_view(17, limits_sha256);
    bind_optional(ins, 18, s.amends_session_id);
    ins.bind_view(19, s.correction_reason).bind_view(20, prev_sha256).bind_view(21, content).bind(22, session_id);
    ins.run();
    SessionReceipt receipt;
    receipt.session_id = session_id;
    receipt.content_sha256 = content;

    for (const auto& run : s.runs) (void)detail::insert_run(db, run, receipt.session_id);
    for (const auto& f : s.findings) {
        Statement& fnd = prepared(db, b.insert_finding,
            "INSERT INTO findings(session_id, parameter, estimator, value, std_error, limit_value, limit_kind, status, note, tail_number) "
            "VALUES (?,?,?,?,?,?,?,?,?,?)");
        fnd.bind(1, receipt.session_id).bind_view(2, f.parameter).bind_view(3, f.estimator);
        bind_optional(fnd, 4, f.value);
        bind_optional(fnd, 5, f.std_error);
        bind_optional(fnd, 6, f.limit_value);
        fnd.bind_view(7, f.limit_kind).bind_view(8, f.status).bind_view(9, f.note).bind_view(10, s.tail_number).run();
    }
    for (const auto& a : s.artifacts) {
        Statement& art = prepared(db, b.insert_artifact, "INSERT INTO session_artifacts(session_id, role, name, sha256) VALUES (?,?,?,?)");
        art.bind(1, receipt.session_id).bind_view(2, a.role).bind_view(3, a.name).bind_view(4, a.sha256).run();
    }
    // An installation change: the position shows a serial other than the one installed there so far.
    if (s.position && !s.actuator_serial.empty()) {
        const std::optional<PositionStatus>& now = position_row(db, b, s.tail_number, *s.position);
        const std::optional<std::string> installed = now ? std::optional<std::string>(now->actuator_serial) : std::nullopt;
        if (!installed || *installed != s.actuator_serial) {
            StoredInstallation inst;
            inst.tail_number = s.tail_number;
            inst.position = *s.position;
            inst.from_serial = installed.value_or("");
            inst.to_serial = s.actuator_serial;
            inst.detected_utc = s.started_utc;
            inst.cycles = s.cycles;
            inst.hours_h = s.hours_h;
            inst.session_id = receipt.session_id;
            Statement& ii = db.cached(
                "INSERT INTO installations(tail_number, position, from_serial, to_serial, detected_utc, cycles, hours_h, session_id) "
                "VALUES (?,?,?,?,?,?,?,?)");
            ii.bind(1, inst.tail_number).bind(2, inst.position).bind(3, inst.from_serial).bind(4, inst.to_serial).bind(5, inst.detected_utc);
            bind_optional(ii, 6, inst.cycles);
            bind_optional(ii, 7, inst.hours_h);
            ii.bind(8, inst.session_id).run();
            inst.installation_id = db.last_insert_id();
            receipt.installation = inst;
        }
    }
    set_chain_head(b, s.tail_number, receipt.session_id, content);
    if (amended) add_to_summaries(db, b, *amended, amended->session_id, -1);
    add_to_summaries(db, b, s, receipt.session_id, +1);
    return receipt;
}

/// The tails a batch appended to (for the anchor file), before flush() clears the batch.
std::vector<std::string> tails_of(const Batch& b) {
    std::vector<std::string> tails;
    for (const auto& [tail, head] : b.heads) tails.push_back(tail);
    std::sort(tails.begin(), tails.end());
    return tails;
}

/// Throws DbError (kind BrokenChain) unless the tail's whole record verifies (verify_tail): a store
/// never appends to a broken chain. The message names the tail and the first problem.
void require_intact(Database& db, const std::string& tail) {
    {
        // Verified whole by this connection, and nobody has appended since: the head check inside
        // the transaction (check_chain_head) is enough.
        Statement& head = db.cached("SELECT content_sha256 FROM chain_heads WHERE tail_number = ?");
        head.bind(1, tail);
        const std::string now = head.step() ? head.column_text(0) : "";
        head.reset();
        if (!now.empty() && db.verified_head(tail) == now) return;
    }
    const ChainCheck c = verify_tail(db, tail, /*compare_anchor=*/false);
    if (c.ok()) {
        db.set_verified_head(tail, c.head_sha256);
        return;
    }
    throw DbError("tail " + tail + ": its record was changed outside the tool (" + std::to_string(c.problems.size()) +
                      " problem(s); the first: " + c.problems.front() + "); nothing was stored: nothing is appended to a broken chain (`emadiag verify --tail " +
                      tail + "` lists every problem; restore the database from a backup)",
                  DbErrorKind::BrokenChain);
}
}  // namespace

struct SessionBatch::State {
    explicit State(Database& d) : db(d) {}
    Database& db;
    std::optional<Transaction> tx;
    Batch b;
    std::map<std::string, bool> verified;  ///< tails whose whole record was verified in this batch
    bool committed = false;
};

SessionBatch::SessionBatch(Database& db) : state_(std::make_unique<State>(db)) {}
SessionBatch::~SessionBatch() = default;  // an open transaction rolls back (Transaction's destructor)

SessionReceipt SessionBatch::add(const StoredTestSession& session) {
    State& st = *state_;
    if (st.committed) throw DbError("session batch on " + st.db.path() + " already committed", DbErrorKind::Invalid);
    check_session(session);
    if (st.verified.emplace(session.tail_number, true).second) {
        // The first tail is verified before the write lock is taken (reading a long record must not
        // hold other writers off); a later one inside the transaction.
        require_intact(st.db, session.tail_number);
    }
    if (!st.tx) st.tx.emplace(st.db);
    return insert_session(st.db, st.b, session);
}

void SessionBatch::commit() {
    State& st = *state_;
    if (st.committed) throw DbError("session batch on " + st.db.path() + " already committed", DbErrorKind::Invalid);
    st.committed = true;
    if (!st.tx) return;  // nothing added
    const std::vector<std::string> tails = tails_of(st.b);
    std::vector<std::pair<std::string, std::string>> heads;  // each verified tail's new head
    for (const auto& [tail, h] : st.b.heads) heads.emplace_back(tail, h.sha);
    flush(st.db, st.b);
    st.tx->commit();
    for (auto& [tail, sha] : heads) st.db.set_verified_head(tail, std::move(sha));
    detail::append_anchor(st.db, tails);
}

SessionReceipt store_session(Database& db, const StoredTestSession& session) {
    SessionBatch batch(db);
    SessionReceipt receipt = batch.add(session);
    batch.commit();
    return receipt;
}

std::vector<SessionReceipt> store_sessions(Database& db, const std::vector<StoredTestSession>& sessions) {
    for (std::size_t i = 0; i < sessions.size(); ++i) {
        try {
            check_session(sessions[i]);
        } catch (const DbError& e) {
            throw DbError("batch session " + std::to_string(i) + ": " + std::string(e.what()).substr(std::string("[maintenance_db] ").size()),
                          e.kind());
        }
    }
    std::vector<SessionReceipt> out;
    out.reserve(sessions.size());
    Transaction tx(db);
    Batch b;  // checks each tail's chain head (one session's reads per tail) before appending to it
    for (const auto& s : sessions) out.push_back(insert_session(db, b, s));
    const std::vector<std::string> tails = tails_of(b);
    flush(db, b);
    tx.commit();
    detail::append_anchor(db, tails);
    return out;
}

std::int64_t store_test_session(Database& db, const StoredTestSession& session) { return store_session(db, session).session_id; }

void detail::seal_sessions_before_v3(Database& db) {
    std::vector<std::int64_t> ids;
    {
        Statement st(db, "SELECT session_id FROM test_sessions ORDER BY session_id");
        while (st.step()) ids.push_back(st.column_int(0));
    }
    Batch b;
    b.check_heads = false;
    for (const auto id : ids) {
        StoredTestSession s = load_session(db, id, FindingsLayout::BySession);  // the version-3 layout
        s.limits_sha256 = sha256_hex(s.limits_json);
        s.prev_sha256 = chain_head(db, b, s.tail_number);
        s.content_sha256 = session_content_sha256(s, s.prev_sha256);
        Statement up(db, "UPDATE test_sessions SET limits_sha256 = ?, prev_sha256 = ?, content_sha256 = ? WHERE session_id = ?");
        up.bind(1, s.limits_sha256).bind(2, s.prev_sha256).bind(3, s.content_sha256).bind(4, id).run();
        set_chain_head(b, s.tail_number, id, s.content_sha256);
        add_to_summaries(db, b, s, id, +1);
    }
    flush(db, b);
}

}  // namespace emadiag::db
