#pragma once
// Where the reports (report, fleet, trend) read the maintenance record from: the station's SQLite
// file or a fleet server (PostgreSQL, emadiag/db/pg_record_source.hpp). Both fill the same
// structures the renderers consume, so a report reads the same from either engine.
#include "emadiag/db/database.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/session_store.hpp"

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace emadiag::db {

class RecordSource {
public:
    virtual ~RecordSource() = default;
    /// What the reports name the database by: the SQLite path, or the server URI as given.
    [[nodiscard]] virtual const std::string& name() const = 0;
    /// Every tail number, sorted (byte order).
    [[nodiscard]] virtual std::vector<std::string> tail_numbers() = 0;
    /// As list_test_sessions / list_sessions_of_serial, with the parts asked for (a report needs
    /// neither the artifacts nor the runs: SessionListParts{false, false}).
    [[nodiscard]] virtual std::vector<StoredTestSession> sessions_of_tail(const std::string& tail_number, const SessionListParts& parts) = 0;
    [[nodiscard]] virtual std::vector<StoredTestSession> sessions_of_serial(const std::string& actuator_serial, const SessionListParts& parts) = 0;
    [[nodiscard]] std::vector<StoredTestSession> sessions_of_tail(const std::string& tail_number) { return sessions_of_tail(tail_number, {}); }
    [[nodiscard]] std::vector<StoredTestSession> sessions_of_serial(const std::string& actuator_serial) {
        return sessions_of_serial(actuator_serial, {});
    }
    /// Whether the serial has a session on a tail other than `tail_number`.
    [[nodiscard]] virtual bool serial_seen_elsewhere(const std::string& actuator_serial, const std::string& tail_number) = 0;
    /// As list_installations / list_installations_of_serial / list_discovery_findings.
    [[nodiscard]] virtual std::vector<StoredInstallation> installations_of_tail(const std::string& tail_number) = 0;
    [[nodiscard]] virtual std::vector<StoredInstallation> installations_of_serial(const std::string& actuator_serial) = 0;
    [[nodiscard]] virtual std::vector<StoredDiscoveryFinding> discovery_findings(const std::string& tail_number, bool open_only) = 0;
    /// As list_positions / list_series_stats (all) / list_position_status.
    [[nodiscard]] virtual std::vector<StoredPosition> positions() = 0;
    [[nodiscard]] virtual std::vector<SeriesStats> series_stats() = 0;
    [[nodiscard]] virtual std::vector<PositionStatus> position_status() = 0;
    /// The problems verify_tail finds in the tail's record (empty: intact, or not checkable here:
    /// a fleet server keeps the hashes the stations sent, and each station verifies its own file).
    [[nodiscard]] virtual std::vector<std::string> record_problems(const std::string& /*tail_number*/) { return {}; }
};

/// The station's SQLite file (the functions of session_store.hpp and record_store.hpp).
class SqliteRecordSource final : public RecordSource {
public:
    explicit SqliteRecordSource(Database& db) : db_(db) {}
    [[nodiscard]] const std::string& name() const override { return db_.path(); }
    [[nodiscard]] std::vector<std::string> tail_numbers() override;
    using RecordSource::sessions_of_serial;
    using RecordSource::sessions_of_tail;
    [[nodiscard]] std::vector<StoredTestSession> sessions_of_tail(const std::string& tail_number, const SessionListParts& parts) override;
    [[nodiscard]] std::vector<StoredTestSession> sessions_of_serial(const std::string& actuator_serial, const SessionListParts& parts) override;
    [[nodiscard]] bool serial_seen_elsewhere(const std::string& actuator_serial, const std::string& tail_number) override;
    [[nodiscard]] std::vector<StoredInstallation> installations_of_tail(const std::string& tail_number) override;
    [[nodiscard]] std::vector<StoredInstallation> installations_of_serial(const std::string& actuator_serial) override;
    [[nodiscard]] std::vector<StoredDiscoveryFinding> discovery_findings(const std::string& tail_number, bool open_only) override;
    [[nodiscard]] std::vector<StoredPosition> positions() override;
    [[nodiscard]] std::vector<SeriesStats> series_stats() override;
    [[nodiscard]] std::vector<PositionStatus> position_status() override;
    [[nodiscard]] std::vector<std::string> record_problems(const std::string& tail_number) override;

private:
    Database& db_;
};

}  // namespace emadiag::db
