#pragma once
// The EMA interface control document (can_dbc/ema.dbc, compiled in) as typed C++: message ids,
// enums that mirror the VAL_ tables, and codecs for each message built on the DBC codec.
#include "emadiag/can/can_frame.hpp"
#include "emadiag/can/crc8.hpp"
#include "emadiag/can/dbc.hpp"

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace emadiag::can {

/// The text of can_dbc/ema.dbc, compiled into the library.
[[nodiscard]] std::string_view ema_dbc_text();
/// ema.dbc parsed once.
[[nodiscard]] const Database& ema_database();
/// What `db` lacks of the ICD the tool speaks: each message (by standard id and name) and signal
/// (by name) that the codec below reads or writes, as "message EMA_Status (standard id 0x010)" or
/// "signal EMA_TelemetryA.MotorCurrent"; empty when nothing is missing.
[[nodiscard]] std::vector<std::string> missing_icd_items(const Database& db);
/// Makes the DBC at `path` (an actuator's own ICD, `emadiag --dbc FILE`) the database of
/// ema_database() and of every EmaIcd built afterwards; call it before the first. Throws CanError
/// naming every missing message and signal, or the parser's problems; returns the parser's
/// warnings (lenient mode).
std::vector<std::string> use_ema_dbc_file(const std::string& path, DbcMode mode = DbcMode::Lenient);

namespace icd {
inline constexpr std::uint32_t kToolCommandId = 0x010;
inline constexpr std::uint32_t kToolHeartbeatId = 0x011;
inline constexpr std::uint32_t kStatusId = 0x020;
inline constexpr std::uint32_t kCommandAckId = 0x021;
inline constexpr std::uint32_t kIdentId = 0x022;
inline constexpr std::uint32_t kTelemetryAId = 0x100;
inline constexpr std::uint32_t kTelemetryBId = 0x101;
inline constexpr std::chrono::milliseconds kHeartbeatPeriod{20};
inline constexpr std::chrono::milliseconds kHeartbeatTimeout{100};
inline constexpr std::chrono::milliseconds kStatusPeriod{20};
inline constexpr std::size_t kTelemetryCrcBytes = 7;  ///< CRC over bytes 0..6, CRC in byte 7
inline constexpr int kIdentPages = 5;
inline constexpr std::uint32_t kCounterModulo = 16;

enum class Command : std::uint8_t { None = 0, EnterGroundTest = 1, LeaveGroundTest = 2, StartSequence = 3, Abort = 4, RequestIdent = 5 };
enum class Mode : std::uint8_t { Off = 0, Normal = 1, GroundTest = 2, Fault = 3 };
enum class SequenceState : std::uint8_t { Idle = 0, Running = 1, Done = 2, Aborted = 3 };
enum class TestSequence : std::uint8_t { None = 0, Dyn = 1, Brk = 2 };
enum class LoadCase : std::uint8_t { A = 0, AExt = 1, B = 2 };
enum class FaultCode : std::uint8_t { None = 0, HeartbeatLost = 1, AbortedByTool = 2, SimulationFailed = 3 };
enum class AckResult : std::uint8_t {
    Accepted = 0, RefusedWeightOnWheels = 1, RefusedMaintenanceDisabled = 2, RefusedNotInGroundTest = 3,
    RefusedBusy = 4, RefusedBadArgument = 5, RefusedUnknownCommand = 6
};
}  // namespace icd

struct EmaStatus {
    icd::Mode mode = icd::Mode::Normal;
    bool weight_on_wheels = true;
    bool maintenance_enable = true;
    icd::SequenceState state = icd::SequenceState::Idle;
    icd::TestSequence sequence = icd::TestSequence::None;
    icd::LoadCase load_case = icd::LoadCase::A;
    std::uint8_t counter = 0;
    std::uint16_t session_id = 0;
    std::uint16_t samples_sent = 0;
    icd::FaultCode fault = icd::FaultCode::None;
};

struct ToolCommand {
    icd::Command command = icd::Command::None;
    icd::TestSequence sequence = icd::TestSequence::None;  ///< START_SEQUENCE only
    std::uint16_t session_id = 0;                          ///< START_SEQUENCE only
};

struct CommandAck {
    icd::Command command = icd::Command::None;
    icd::AckResult result = icd::AckResult::Accepted;
    std::uint16_t session_id = 0;
};

struct EmaIdentification {
    std::uint32_t serial_number = 0;
    std::uint32_t part_number = 0;
    std::uint8_t firmware_major = 0, firmware_minor = 0, firmware_patch = 0;
    double k_t_nm_per_a = 0;     ///< float32 on the bus
    double j_kgm2 = 0;           ///< float32 on the bus
    double tau = 0;              ///< float32 on the bus
    double sample_period_s = 0;  ///< 1 us resolution on the bus
};

/// One decoded telemetry half-frame. `crc_ok` compares the CRC byte with CRC-8 of bytes 0..6.
struct TelemetryA {
    std::uint16_t index = 0;
    std::uint8_t counter = 0;
    double current_a = 0;
    double speed_rad_s = 0;
    bool crc_ok = false;
};
struct TelemetryB {
    std::uint16_t index = 0;
    std::uint8_t counter = 0;
    double theta_m_rad = 0;
    double hinge_moment_nm = 0;
    bool crc_ok = false;
};

/// Collects the five EMA_Ident pages.
class IdentAssembler {
public:
    void add(int page, const std::vector<DecodedSignal>& values);
    [[nodiscard]] bool complete() const { return pages_ == (1u << icd::kIdentPages) - 1; }
    [[nodiscard]] const EmaIdentification& identification() const { return ident_; }

private:
    unsigned pages_ = 0;
    EmaIdentification ident_;
};

/// Typed codec of the ICD messages. Construction looks up every message and signal of
/// ema.dbc and throws CanError naming the first that is missing.
class EmaIcd {
public:
    EmaIcd();
    explicit EmaIcd(const Database& db);

    const Database& db;
    const Message& command;
    const Message& heartbeat;
    const Message& status;
    const Message& ack;
    const Message& ident;
    const Message& telemetry_a;
    const Message& telemetry_b;

    [[nodiscard]] CanFrame encode_command(const ToolCommand& c) const;
    [[nodiscard]] CanFrame encode_heartbeat(std::uint8_t counter) const;
    [[nodiscard]] CanFrame encode_status(const EmaStatus& s) const;
    [[nodiscard]] CanFrame encode_ack(const CommandAck& a) const;
    [[nodiscard]] std::vector<CanFrame> encode_ident(const EmaIdentification& id) const;
    /// Telemetry frames with counter and CRC filled in. Values beyond the signal range throw.
    [[nodiscard]] CanFrame encode_telemetry_a(std::uint16_t index, std::uint8_t counter, double current_a, double speed_rad_s) const;
    [[nodiscard]] CanFrame encode_telemetry_b(std::uint16_t index, std::uint8_t counter, double theta_m_rad, double hinge_moment_nm) const;

    /// Decoders return nullopt when the frame is not that message or is too short.
    [[nodiscard]] std::optional<ToolCommand> decode_command(const CanFrame& f) const;
    [[nodiscard]] std::optional<EmaStatus> decode_status(const CanFrame& f) const;
    [[nodiscard]] std::optional<CommandAck> decode_ack(const CanFrame& f) const;
    /// Feeds an EMA_Ident frame to `assembler`; false when `f` is not a valid EMA_Ident frame.
    [[nodiscard]] bool decode_ident(const CanFrame& f, IdentAssembler& assembler) const;
    /// Fast telemetry decoders (the hot path of the recorder, see bench/can_decode_bench.cpp).
    [[nodiscard]] bool decode_telemetry_a(const CanFrame& f, TelemetryA& out) const {
        if (f.id != icd::kTelemetryAId || f.extended || f.len < telemetry_a.length) return false;
        const std::uint8_t* d = f.data.data();
        out.index = static_cast<std::uint16_t>(a_index_->extract_raw(d));
        out.counter = static_cast<std::uint8_t>(a_counter_->extract_raw(d));
        out.current_a = a_current_->raw_to_physical(a_current_->extract_raw(d));
        out.speed_rad_s = a_speed_->raw_to_physical(a_speed_->extract_raw(d));
        out.crc_ok = crc_matches(d, a_crc_->extract_raw(d));
        return true;
    }
    [[nodiscard]] bool decode_telemetry_b(const CanFrame& f, TelemetryB& out) const {
        if (f.id != icd::kTelemetryBId || f.extended || f.len < telemetry_b.length) return false;
        const std::uint8_t* d = f.data.data();
        out.index = static_cast<std::uint16_t>(b_index_->extract_raw(d));
        out.counter = static_cast<std::uint8_t>(b_counter_->extract_raw(d));
        out.theta_m_rad = b_theta_->raw_to_physical(b_theta_->extract_raw(d));
        out.hinge_moment_nm = b_hinge_->raw_to_physical(b_hinge_->extract_raw(d));
        out.crc_ok = crc_matches(d, b_crc_->extract_raw(d));
        return true;
    }

    /// Signal factors of the telemetry (the sensor resolutions).
    [[nodiscard]] double current_resolution_a() const { return a_current_->factor; }
    [[nodiscard]] double speed_resolution_rad_s() const { return a_speed_->factor; }
    [[nodiscard]] double theta_resolution_rad() const { return b_theta_->factor; }
    [[nodiscard]] double hinge_resolution_nm() const { return b_hinge_->factor; }

    /// VAL_ text of a value ("REFUSED_WEIGHT_ON_WHEELS"), or the number when it has none.
    [[nodiscard]] std::string value_name(const Message& m, std::string_view signal, std::int64_t value) const;

private:
    static bool crc_matches(const std::uint8_t* d, std::uint64_t crc) {
        return crc8_j1850(d, icd::kTelemetryCrcBytes) == crc;
    }
    const Signal* a_index_;
    const Signal* a_counter_;
    const Signal* a_current_;
    const Signal* a_speed_;
    const Signal* a_crc_;
    const Signal* b_index_;
    const Signal* b_counter_;
    const Signal* b_theta_;
    const Signal* b_hinge_;
    const Signal* b_crc_;
};

}  // namespace emadiag::can
