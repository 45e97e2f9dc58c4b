#include "emadiag/can/ema_icd.hpp"

#include "emadiag/can/can_error.hpp"

#include <cmath>
#include <memory>

namespace emadiag::can {
namespace {

const Message& need(const Database& db, std::uint32_t id, const char* name) {
    const Message* m = db.find_message(id, false);
    if (m == nullptr || m->name != name)
        throw CanError(std::string("the ICD has no message ") + name + " with id " + format_id(id, false));
    return *m;
}

const Signal* sig(const Message& m, const char* name) { return &m.signals[m.signal_index(name)]; }

double value_of(const std::vector<DecodedSignal>& v, std::string_view name) {
    for (const auto& d : v)
        if (d.signal->name == name) return d.value;
    return 0;
}

}  // namespace

namespace {

/// What the tool reads and writes of each ICD message (every name ema_icd.cpp uses).
struct Needed {
    std::uint32_t id;
    const char* message;
    std::vector<const char*> signals;
};
const std::vector<Needed>& needed() {
    static const std::vector<Needed> n = {
        {icd::kToolCommandId, "TOOL_Command", {"Command", "Sequence", "SessionId"}},
        {icd::kToolHeartbeatId, "TOOL_Heartbeat", {"HeartbeatCounter"}},
        {icd::kStatusId, "EMA_Status", {"Mode", "WeightOnWheels", "MaintenanceEnable", "SequenceState", "ActiveSequence", "LoadCase",
                                        "StatusCounter", "StatusSessionId", "SamplesSent", "FaultCode"}},
        {icd::kCommandAckId, "EMA_CommandAck", {"AckCommand", "AckResult", "AckSessionId"}},
        {icd::kIdentId, "EMA_Ident", {"IdentPage", "SerialNumber", "FirmwareMajor", "FirmwareMinor", "FirmwarePatch", "PartNumber",
                                      "SamplePeriod", "TorqueConstant", "Inertia", "GearRatio"}},
        {icd::kTelemetryAId, "EMA_TelemetryA", {"SampleIndexA", "CounterA", "MotorCurrent", "MotorSpeed", "CrcA"}},
        {icd::kTelemetryBId, "EMA_TelemetryB", {"SampleIndexB", "CounterB", "MotorAngle", "HingeMoment", "CrcB"}},
    };
    return n;
}

/// The DBC given at run time (--dbc); null: the built-in ema.dbc.
std::unique_ptr<Database>& run_time_database() {
    static std::unique_ptr<Database> db;
    return db;
}

}  // namespace

std::vector<std::string> missing_icd_items(const Database& db) {
    std::vector<std::string> missing;
    for (const auto& n : needed()) {
        const Message* m = db.find_message(n.id, false);
        if (m == nullptr || m->name != n.message) {
            missing.push_back(std::string("message ") + n.message + " (standard id " + format_id(n.id, false) + ")" +
                              (m != nullptr ? ": that id is message '" + m->name + "'" : std::string()));
            continue;
        }
        for (const char* sname : n.signals)
            if (m->find_signal(sname) == nullptr) missing.push_back(std::string("signal ") + n.message + "." + sname);
    }
    return missing;
}

std::vector<std::string> use_ema_dbc_file(const std::string& path, DbcMode mode) {
    auto db = std::make_unique<Database>(parse_dbc_file(path, mode));
    const auto missing = missing_icd_items(*db);
    if (!missing.empty()) {
        std::string all = path + ": this DBC lacks " + std::to_string(missing.size()) + " item" + (missing.size() == 1 ? "" : "s") +
                          " of the EMA ICD the tool needs (can_dbc/ICD.md):";
        for (const auto& m : missing) all += "\n  " + m;
        throw CanError(all);
    }
    (void)EmaIcd(*db);  // the layout checks of the codec (CRC position)
    std::vector<std::string> warnings = db->warnings;
    run_time_database() = std::move(db);
    return warnings;
}

const Database& ema_database() {
    if (const auto& db = run_time_database()) return *db;
    static const Database db = parse_dbc(ema_dbc_text(), "ema.dbc", DbcMode::Strict);
    return db;
}

EmaIcd::EmaIcd() : EmaIcd(ema_database()) {}

EmaIcd::EmaIcd(const Database& database)
    : db(database),
      command(need(database, icd::kToolCommandId, "TOOL_Command")),
      heartbeat(need(database, icd::kToolHeartbeatId, "TOOL_Heartbeat")),
      status(need(database, icd::kStatusId, "EMA_Status")),
      ack(need(database, icd::kCommandAckId, "EMA_CommandAck")),
      ident(need(database, icd::kIdentId, "EMA_Ident")),
      telemetry_a(need(database, icd::kTelemetryAId, "EMA_TelemetryA")),
      telemetry_b(need(database, icd::kTelemetryBId, "EMA_TelemetryB")),
      a_index_(sig(telemetry_a, "SampleIndexA")),
      a_counter_(sig(telemetry_a, "CounterA")),
      a_current_(sig(telemetry_a, "MotorCurrent")),
      a_speed_(sig(telemetry_a, "MotorSpeed")),
      a_crc_(sig(telemetry_a, "CrcA")),
      b_index_(sig(telemetry_b, "SampleIndexB")),
      b_counter_(sig(telemetry_b, "CounterB")),
      b_theta_(sig(telemetry_b, "MotorAngle")),
      b_hinge_(sig(telemetry_b, "HingeMoment")),
      b_crc_(sig(telemetry_b, "CrcB")) {
    if (a_crc_->start_bit != 8 * icd::kTelemetryCrcBytes || b_crc_->start_bit != 8 * icd::kTelemetryCrcBytes)
        throw CanError("the ICD's telemetry CRC signals must occupy byte 7");
}

CanFrame EmaIcd::encode_command(const ToolCommand& c) const {
    std::vector<std::pair<std::string, double>> v{{"Command", static_cast<double>(c.command)}};
    if (c.command == icd::Command::StartSequence) {
        v.emplace_back("Sequence", static_cast<double>(c.sequence));
        v.emplace_back("SessionId", c.session_id);
    }
    return command.encode_frame(v);
}

CanFrame EmaIcd::encode_heartbeat(std::uint8_t counter) const {
    return heartbeat.encode_frame({{"HeartbeatCounter", counter}});
}

CanFrame EmaIcd::encode_status(const EmaStatus& s) const {
    return status.encode_frame({{"Mode", static_cast<double>(s.mode)},
                                {"WeightOnWheels", s.weight_on_wheels ? 1 : 0},
                                {"MaintenanceEnable", s.maintenance_enable ? 1 : 0},
                                {"SequenceState", static_cast<double>(s.state)},
                                {"ActiveSequence", static_cast<double>(s.sequence)},
                                {"LoadCase", static_cast<double>(s.load_case)},
                                {"StatusCounter", s.counter % icd::kCounterModulo},
                                {"StatusSessionId", s.session_id},
                                {"SamplesSent", s.samples_sent},
                                {"FaultCode", static_cast<double>(s.fault)}});
}

CanFrame EmaIcd::encode_ack(const CommandAck& a) const {
    return ack.encode_frame({{"AckCommand", static_cast<double>(a.command)},
                             {"AckResult", static_cast<double>(a.result)},
                             {"AckSessionId", a.session_id}});
}

std::vector<CanFrame> EmaIcd::encode_ident(const EmaIdentification& id) const {
    return {ident.encode_frame({{"IdentPage", 0},
                                {"SerialNumber", id.serial_number},
                                {"FirmwareMajor", id.firmware_major},
                                {"FirmwareMinor", id.firmware_minor},
                                {"FirmwarePatch", id.firmware_patch}}),
            ident.encode_frame({{"IdentPage", 1}, {"PartNumber", id.part_number}, {"SamplePeriod", id.sample_period_s}}),
            ident.encode_frame({{"IdentPage", 2}, {"TorqueConstant", id.k_t_nm_per_a}}),
            ident.encode_frame({{"IdentPage", 3}, {"Inertia", id.j_kgm2}}),
            ident.encode_frame({{"IdentPage", 4}, {"GearRatio", id.tau}})};
}

CanFrame EmaIcd::encode_telemetry_a(std::uint16_t index, std::uint8_t counter, double current_a, double speed_rad_s) const {
    CanFrame f;
    f.id = icd::kTelemetryAId;
    f.len = static_cast<std::uint8_t>(telemetry_a.length);
    std::uint8_t* d = f.data.data();
    a_index_->insert_raw(index, d);
    a_counter_->insert_raw(counter % icd::kCounterModulo, d);
    a_current_->insert_raw(a_current_->physical_to_raw(current_a), d);
    a_speed_->insert_raw(a_speed_->physical_to_raw(speed_rad_s), d);
    a_crc_->insert_raw(crc8_j1850(d, icd::kTelemetryCrcBytes), d);
    return f;
}

CanFrame EmaIcd::encode_telemetry_b(std::uint16_t index, std::uint8_t counter, double theta_m_rad, double hinge_moment_nm) const {
    CanFrame f;
    f.id = icd::kTelemetryBId;
    f.len = static_cast<std::uint8_t>(telemetry_b.length);
    std::uint8_t* d = f.data.data();
    b_index_->insert_raw(index, d);
    b_counter_->insert_raw(counter % icd::kCounterModulo, d);
    b_theta_->insert_raw(b_theta_->physical_to_raw(theta_m_rad), d);
    b_hinge_->insert_raw(b_hinge_->physical_to_raw(hinge_moment_nm), d);
    b_crc_->insert_raw(crc8_j1850(d, icd::kTelemetryCrcBytes), d);
    return f;
}

std::optional<ToolCommand> EmaIcd::decode_command(const CanFrame& f) const {
    if (f.id != icd::kToolCommandId || f.extended) return std::nullopt;
    std::vector<DecodedSignal> v;
    if (!command.decode(f.data.data(), f.len, v)) return std::nullopt;
    ToolCommand c;
    c.command = static_cast<icd::Command>(value_of(v, "Command"));
    c.sequence = static_cast<icd::TestSequence>(value_of(v, "Sequence"));
    c.session_id = static_cast<std::uint16_t>(value_of(v, "SessionId"));
    return c;
}

std::optional<EmaStatus> EmaIcd::decode_status(const CanFrame& f) const {
    if (f.id != icd::kStatusId || f.extended) return std::nullopt;
    std::vector<DecodedSignal> v;
    if (!status.decode(f.data.data(), f.len, v)) return std::nullopt;
    EmaStatus s;
    s.mode = static_cast<icd::Mode>(value_of(v, "Mode"));
    s.weight_on_wheels = value_of(v, "WeightOnWheels") != 0;
    s.maintenance_enable = value_of(v, "MaintenanceEnable") != 0;
    s.state = static_cast<icd::SequenceState>(value_of(v, "SequenceState"));
    s.sequence = static_cast<icd::TestSequence>(value_of(v, "ActiveSequence"));
    s.load_case = static_cast<icd::LoadCase>(value_of(v, "LoadCase"));
    s.counter = static_cast<std::uint8_t>(value_of(v, "StatusCounter"));
    s.session_id = static_cast<std::uint16_t>(value_of(v, "StatusSessionId"));
    s.samples_sent = static_cast<std::uint16_t>(value_of(v, "SamplesSent"));
    s.fault = static_cast<icd::FaultCode>(value_of(v, "FaultCode"));
    return s;
}

std::optional<CommandAck> EmaIcd::decode_ack(const CanFrame& f) const {
    if (f.id != icd::kCommandAckId || f.extended) return std::nullopt;
    std::vector<DecodedSignal> v;
    if (!ack.decode(f.data.data(), f.len, v)) return std::nullopt;
    CommandAck a;
    a.command = static_cast<icd::Command>(value_of(v, "AckCommand"));
    a.result = static_cast<icd::AckResult>(value_of(v, "AckResult"));
    a.session_id = static_cast<std::uint16_t>(value_of(v, "AckSessionId"));
    return a;
}

bool EmaIcd::decode_ident(const CanFrame& f, IdentAssembler& assembler) const {
    if (f.id != icd::kIdentId || f.extended) return false;
    std::vector<DecodedSignal> v;
    if (!ident.decode(f.data.data(), f.len, v)) return false;
    const auto page = static_cast<int>(value_of(v, "IdentPage"));
    if (page < 0 || page >= icd::kIdentPages) return false;
    assembler.add(page, v);
    return true;
}

void IdentAssembler::add(int page, const std::vector<DecodedSignal>& v) {
    switch (page) {
        case 0:
            ident_.serial_number = static_cast<std::uint32_t>(value_of(v, "SerialNumber"));
            ident_.firmware_major = static_cast<std::uint8_t>(value_of(v, "FirmwareMajor"));
            ident_.firmware_minor = static_cast<std::uint8_t>(value_of(v, "FirmwareMinor"));
            ident_.firmware_patch = static_cast<std::uint8_t>(value_of(v, "FirmwarePatch"));
            break;
        case 1:
            ident_.part_number = static_cast<std::uint32_t>(value_of(v, "PartNumber"));
            ident_.sample_period_s = value_of(v, "SamplePeriod");
            break;
        case 2: ident_.k_t_nm_per_a = value_of(v, "TorqueConstant"); break;
        case 3: ident_.j_kgm2 = value_of(v, "Inertia"); break;
        case 4: ident_.tau = value_of(v, "GearRatio"); break;
        default: return;
    }
    pages_ |= 1u << page;
}

std::string EmaIcd::value_name(const Message& m, std::string_view signal, std::int64_t value) const {
    const Signal* s = m.find_signal(signal);
    if (s != nullptr) {
        auto it = s->value_table.find(value);
        if (it != s->value_table.end()) return it->second;
    }
    return std::to_string(value);
}

}  // namespace emadiag::can
