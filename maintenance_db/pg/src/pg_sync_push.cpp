// emadiag sync, the sender's side: one batch of whole sessions to the fleet server in one transaction
// (COPY of the rows read ahead, samples and raw logs streamed from the station file), then its
// record on the station.
#include "pg_sync_detail.hpp"

#include <sqlite3.h>

#include <algorithm>
#include <mutex>
#include <unordered_map>

namespace emadiag::db::sync_detail {

constexpr std::size_t kRawChunkBytes = 1 << 20;  // raw log chunk: at most 1 MiB on either side

/// The raw logs of the batch's runs as rows of raw_log_chunks, streamed in chunks straight from the
/// SQLite blob (at most kRawChunkBytes each); adds the bytes read to raw_bytes.
void Syncer::put_raw_logs(const std::vector<PreparedBatch::LocalRun>& runs, const std::unordered_map<std::int64_t, std::int64_t>& run_ids,
                          const std::function<void(const std::string&)>& put, std::int64_t& raw_bytes) {
    std::string chunk, line;
    static const char* hex = "0123456789abcdef";
    for (const auto& r : runs) {
        if (r.raw_bytes == 0) continue;
        sqlite3_blob* blob = nullptr;
        if (sqlite3_blob_open(db_.handle(), "main", "raw_logs", "content", r.run_id, 0, &blob) != SQLITE_OK)
            throw DbError("cannot read the raw log of run " + std::to_string(r.run_id) + ": " + db_.error_text());
        const int total = sqlite3_blob_bytes(blob);
        int chunk_index = 0;
        for (int at = 0; at < total; at += static_cast<int>(kRawChunkBytes), ++chunk_index) {
            const int n = std::min(total - at, static_cast<int>(kRawChunkBytes));
            chunk.resize(static_cast<std::size_t>(n));
            if (sqlite3_blob_read(blob, chunk.data(), n, at) != SQLITE_OK) {
                sqlite3_blob_close(blob);
                throw DbError("cannot read the raw log of run " + std::to_string(r.run_id) + ": " + db_.error_text());
            }
            line = std::to_string(run_ids.at(r.run_id)) + '\t' + std::to_string(chunk_index) + "\t\\\\x";
            line.reserve(line.size() + 2 * chunk.size() + 1);
            for (unsigned char c : chunk) {
                line += hex[c >> 4];
                line += hex[c & 15];
            }
            line += '\n';
            put(line);
        }
        sqlite3_blob_close(blob);
        raw_bytes += total;
    }
}

/// One batch of whole sessions in one transaction, then its record on the station.
void Syncer::push_batch(const PreparedBatch& b) {
    const auto& ids = b.ids;
    const std::int64_t lo = b.lo, hi = b.hi;
    const auto& runs = b.runs;
    std::vector<std::int64_t> sids;
    std::int64_t samples = 0, raw_bytes = 0;
    try {
        pg_.exec("BEGIN");
        register_places(b.tails, b.positions);
        sids = reserve("test_sessions", "session_id", ids.size());
        const auto rids = reserve("runs", "run_id", runs.size());
        std::unordered_map<std::int64_t, std::int64_t> batch_ids, run_ids;
        for (std::size_t i = 0; i < ids.size(); ++i) batch_ids[ids[i]] = sids[i];
        for (std::size_t i = 0; i < runs.size(); ++i) run_ids[runs[i].run_id] = rids[i];
        const auto fleet = [&](std::int64_t local) {
            const auto it = batch_ids.find(local);
            return it != batch_ids.end() ? it->second : fleet_session_of(local);
        };
        pg_.copy_in("test_sessions (session_id, session_uuid, station_uuid, station_session_id, tail_number, position, actuator_serial, "
                    "phase, started_utc, cycles, hours_h, operator_id, technician_name, technician_certificate, work_performed, source, "
                    "tool_version, verdict, verdict_note, limits_json, limits_sha256, correction_reason, prev_sha256, content_sha256, "
                    "amends_session_id)",
                    [&](const auto& put) {
                        std::string line;
                        for (const auto& s : b.sessions) {
                            line = std::to_string(sids[s.index]);
                            line += s.rest;
                            line += s.amends ? std::to_string(fleet(*s.amends)) : "\\N";
                            line += '\n';
                            put(line);
                        }
                    });
        if (!runs.empty()) {
            pg_.copy_in("runs (run_id, session_id, tail_number, actuator_serial, started_utc, source, load_case, sequence, k_t_nm_per_a, j_kgm2, "
                        "tau, sample_period_s, valid, status_note, meta_json, raw_log_format, raw_log_bytes)",
                        [&](const auto& put) {
                            for (const auto& r : runs) put(std::to_string(run_ids.at(r.run_id)) + '\t' + std::to_string(batch_ids.at(r.session_id)) + '\t' + r.line + '\n');
                        });
            pg_.copy_in("estimates (run_id, estimator, parameter, value, std_error, identifiable, method, note)", [&](const auto& put) {
                Statement st(db_, "SELECT e.run_id, e.estimator, e.parameter, e.value, e.std_error, e.identifiable, e.method, e.note FROM estimates e "
                                  "JOIN runs r ON r.run_id = e.run_id WHERE r.session_id BETWEEN ? AND ?");
                st.bind(1, lo).bind(2, hi);
                while (st.step())
                    put(std::to_string(run_ids.at(st.column_int(0))) + '\t' + f(st.column_text(1)) + '\t' + f(st.column_text(2)) + '\t' +
                        opt_d(col_opt_d(st, 3)) + '\t' + d2s(st.column_double(4)) + '\t' + (st.column_int(5) != 0 ? "t" : "f") + '\t' +
                        f(st.column_text(6)) + '\t' + f(st.column_text(7)) + '\n');
            });
            // Samples streamed from the station file: never all in memory.
            pg_.copy_in("samples (run_id, sample_index, t_s, current_a, speed_rad_s, theta_m_rad, hinge_moment_nm, command_deg)",
                        [&](const auto& put) {
                            Statement st(db_, "SELECT x.run_id, x.sample_index, x.t_s, x.current_a, x.speed_rad_s, x.theta_m_rad, "
                                              "x.hinge_moment_nm, x.command_deg FROM samples x JOIN runs r ON r.run_id = x.run_id "
                                              "WHERE r.session_id BETWEEN ? AND ?");
                            st.bind(1, lo).bind(2, hi);
                            std::string line;
                            while (st.step()) {
                                line = std::to_string(run_ids.at(st.column_int(0))) + '\t' + std::to_string(st.column_int(1));
                                for (int c = 2; c < 8; ++c) line += '\t' + d2s(st.column_double(c));
                                line += '\n';
                                put(line);
                                ++samples;
                            }
                        });
            // Raw logs streamed in chunks straight from the SQLite blob.
            pg_.copy_in("raw_log_chunks (run_id, chunk_index, content)", [&](const auto& put) { put_raw_logs(runs, run_ids, put, raw_bytes); });
        }
        pg_.copy_in(std::string("findings (session_id, parameter, estimator, value, std_error, limit_value, limit_kind, status, note") +
                        (server_version_ >= 3 ? ", tail_number)" : ")"),
                    [&](const auto& put) {
                        std::string line;
                        for (const auto& x : b.findings) {
                            line = std::to_string(sids[x.index]);
                            line += x.rest;
                            put(line);
                        }
                    });
        pg_.copy_in("session_artifacts (session_id, role, name, sha256)", [&](const auto& put) {
            for (const auto& a : b.artifacts) put(std::to_string(batch_ids.at(a.session_id)) + a.rest);
        });
        pg_.copy_in("installations (tail_number, position, from_serial, to_serial, detected_utc, cycles, hours_h, session_id)", [&](const auto& put) {
            for (const auto& i : b.installations) put(i.rest + std::to_string(batch_ids.at(i.session_id)) + '\n');
        });
        pg_.copy_in("session_measurements (session_id, ordinal, sign, of_session_id, tail_number, position, actuator_serial, parameter, days, "
                    "w, wy, wyy, cycles, value, std_error, limit_kind, limit_value)",
                    [&](const auto& put) {
                        std::string line;
                        for (const auto& t : b.terms) {
                            line = std::to_string(batch_ids.at(t.session_id));
                            line += '\t';
                            line += std::to_string(t.ordinal);
                            line += '\t';
                            line += std::to_string(t.sign);
                            line += '\t';
                            line += std::to_string(fleet(t.of_session_id));
                            line += t.rest;
                            put(line);
                        }
                    });
        pg_.exec("COMMIT");
    } catch (const DbError& e) {
        std::string m = e.what();
        if (m.rfind("[maintenance_db] ", 0) == 0) m = m.substr(17);
        throw DbError("sessions " + std::to_string(lo) + ".." + std::to_string(hi) + " of " + db_.path() + ": " + m, e.kind());
    }
    // Only now is the batch on the server: record it on the station (once the reader thread has
    // read the next batch: the station file takes one writer and no readers at a time).
    {
        const std::lock_guard<std::mutex> gate(station_gate_);
        Transaction tx(db_);
        Statement& rec = db_.cached("INSERT INTO synced_sessions(server, session_id, fleet_session_id, synced_utc) VALUES (?,?,?,?)");
        const std::string now = now_iso();
        for (std::size_t i = 0; i < ids.size(); ++i) {
            rec.reset();
            rec.bind(1, server_).bind(2, ids[i]).bind(3, sids[i]).bind(4, now).run();
        }
        tx.commit();
    }
    res_.sessions_pushed += static_cast<std::int64_t>(ids.size());
    res_.runs += static_cast<std::int64_t>(runs.size());
    res_.samples += samples;
    res_.raw_log_bytes += raw_bytes;
    ++res_.batches;
    progress("sessions " + std::to_string(lo) + ".." + std::to_string(hi) + " -> fleet sessions " + std::to_string(sids.front()) + ".." +
             std::to_string(sids.back()) + " committed");
}

}  // namespace emadiag::db::sync_detail
