#include "emadiag/db/record_source.hpp"

namespace emadiag::db {

std::vector<std::string> SqliteRecordSource::tail_numbers() {
    Statement st(db_, "SELECT tail_number FROM aircraft ORDER BY tail_number");
    std::vector<std::string> tails;
    while (st.step()) tails.push_back(st.column_text(0));
    return tails;
}
std::vector<StoredTestSession> SqliteRecordSource::sessions_of_tail(const std::string& t, const SessionListParts& parts) {
    return list_test_sessions(db_, t, parts);
}
std::vector<StoredTestSession> SqliteRecordSource::sessions_of_serial(const std::string& s, const SessionListParts& parts) {
    return list_sessions_of_serial(db_, s, parts);
}
bool SqliteRecordSource::serial_seen_elsewhere(const std::string& serial, const std::string& tail) {
    Statement st(db_, "SELECT 1 FROM test_sessions WHERE actuator_serial = ? AND tail_number != ? LIMIT 1");
    st.bind(1, serial).bind(2, tail);
    return st.step();
}
std::vector<StoredInstallation> SqliteRecordSource::installations_of_tail(const std::string& t) { return list_installations(db_, t); }
std::vector<StoredInstallation> SqliteRecordSource::installations_of_serial(const std::string& s) { return list_installations_of_serial(db_, s); }
std::vector<StoredDiscoveryFinding> SqliteRecordSource::discovery_findings(const std::string& t, bool open_only) {
    return list_discovery_findings(db_, t, open_only);
}
std::vector<StoredPosition> SqliteRecordSource::positions() { return list_positions(db_); }
std::vector<SeriesStats> SqliteRecordSource::series_stats() { return list_series_stats(db_); }
std::vector<PositionStatus> SqliteRecordSource::position_status() { return list_position_status(db_); }
std::vector<std::string> SqliteRecordSource::record_problems(const std::string& t) { return verify_tail(db_, t).problems; }

}  // namespace emadiag::db
