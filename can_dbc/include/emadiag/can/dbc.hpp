#pragma once
// A DBC database: nodes, messages, signals, comments, value tables, attributes.
// parse_dbc() reads standard DBC (Vector CANdb++ format, as read by cantools and SavvyCAN) and
// reports every problem it finds as "file:line:col: message" in one CanError. Like cantools it is
// lenient by default: what cantools' strict=False lets pass (a reference to a message or signal that
// does not exist, CANdb++'s placeholder message, an ENUM value that is not one of its values, an
// attribute value outside its range, a signal beyond its message, a repeated signal or frame id)
// becomes a warning naming the file, line and what was skipped; DbcMode::Strict refuses it.
#include "emadiag/can/can_frame.hpp"

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace emadiag::can {

enum class ByteOrder { LittleEndian /* @1, Intel */, BigEndian /* @0, Motorola */ };
enum class ValueType { Integer, Float32, Float64 };  ///< SIG_VALTYPE_ 0, 1, 2
enum class MuxRole { None, Multiplexor /* M */, Multiplexed /* mN */, MultiplexedMultiplexor /* mNM */ };

struct AttributeValue {
    bool is_string = false;
    double number = 0;
    std::string text;
};

enum class AttributeObject { Network, Node, Message, Signal, EnvVar };
enum class AttributeType { Int, Hex, Float, String, Enum };

struct AttributeDefinition {
    std::string name;
    AttributeObject object = AttributeObject::Network;
    AttributeType type = AttributeType::Int;
    double minimum = 0;
    double maximum = 0;
    std::vector<std::string> enum_values;
    std::optional<AttributeValue> default_value;  ///< BA_DEF_DEF_
};

/// An inclusive range of multiplexor values (SG_MUL_VAL_ "lo-hi").
struct MuxRange {
    std::uint64_t lo = 0;
    std::uint64_t hi = 0;
};

/// Where the bits of a signal sit, precomputed for the fast codec.
struct SignalLayout {
    std::uint32_t first_byte = 0;
    std::uint32_t n_bytes = 0;      ///< bytes touched, 1..9
    std::uint32_t shift = 0;        ///< right shift of the loaded window
    std::uint32_t required_len = 0; ///< payload bytes the signal needs
    std::uint64_t mask = 0;
};

struct Signal {
    std::string name;
    std::uint32_t start_bit = 0;  ///< DBC numbering: LSB for little-endian, MSB for big-endian
    std::uint32_t length = 0;     ///< bits, 1..64
    ByteOrder byte_order = ByteOrder::LittleEndian;
    bool is_signed = false;
    ValueType value_type = ValueType::Integer;
    double factor = 1.0;
    double offset = 0.0;
    double minimum = 0.0;
    double maximum = 0.0;
    std::string unit;
    std::vector<std::string> receivers;
    MuxRole mux_role = MuxRole::None;
    std::uint64_t mux_value = 0;      ///< for Multiplexed: the mN value
    std::string multiplexor;          ///< switch name for multiplexed signals
    std::vector<MuxRange> mux_ranges; ///< values of the switch that select this signal
    std::string comment;
    std::map<std::int64_t, std::string> value_table;  ///< VAL_
    std::map<std::string, AttributeValue> attributes;
    SignalLayout layout;

    /// Computes `layout`; returns an error text when the bits do not fit in `message_len` bytes.
    [[nodiscard]] std::optional<std::string> compute_layout(std::size_t message_len);

    /// Fast codec: `data` must hold at least layout.required_len bytes.
    [[nodiscard]] std::uint64_t extract_raw(const std::uint8_t* data) const {
        const SignalLayout& l = layout;
        const std::uint8_t* p = data + l.first_byte;
        if (l.n_bytes <= 8) {
            std::uint64_t v = 0;
            if (byte_order == ByteOrder::LittleEndian) {
                for (std::uint32_t i = 0; i < l.n_bytes; ++i) v |= std::uint64_t{p[i]} << (8 * i);
            } else {
                for (std::uint32_t i = 0; i < l.n_bytes; ++i) v = (v << 8) | p[i];
            }
            return (v >> l.shift) & l.mask;
        }
        return extract_raw_wide(data);
    }
    void insert_raw(std::uint64_t raw, std::uint8_t* data) const;
    /// Slow reference codec, one bit at a time (for tests). Throws CanError if len is too short.
    [[nodiscard]] std::uint64_t extract_raw_reference(const std::uint8_t* data, std::size_t len) const;
    void insert_raw_reference(std::uint64_t raw, std::uint8_t* data, std::size_t len) const;

    /// Raw to physical: sign extension or float reinterpretation, then factor and offset.
    [[nodiscard]] double raw_to_physical(std::uint64_t raw) const {
        switch (value_type) {
            case ValueType::Integer: {
                if (is_signed) {
                    std::uint64_t v = raw;
                    if (length < 64 && (v >> (length - 1)) & 1u) v |= ~layout.mask;
                    return static_cast<double>(static_cast<std::int64_t>(v)) * factor + offset;
                }
                return static_cast<double>(raw) * factor + offset;
            }
            case ValueType::Float32: return float_from_raw32(raw) * factor + offset;
            case ValueType::Float64: return double_from_raw64(raw) * factor + offset;
        }
        return 0;
    }
    /// Physical to raw, rounded to the nearest step. Throws CanError naming the signal, the
    /// value and the raw range when the value cannot be represented (never clamps).
    [[nodiscard]] std::uint64_t physical_to_raw(double physical) const;
    /// Smallest and largest raw integer of the signal, as signed values when is_signed.
    [[nodiscard]] double raw_min() const;
    [[nodiscard]] double raw_max() const;

private:
    [[nodiscard]] std::uint64_t extract_raw_wide(const std::uint8_t* data) const;
    static double float_from_raw32(std::uint64_t raw);
    static double double_from_raw64(std::uint64_t raw);
};

struct DecodedSignal {
    const Signal* signal = nullptr;
    std::uint64_t raw = 0;
    double value = 0;
};

struct Message {
    std::uint32_t id = 0;  ///< without the DBC extended flag
    bool extended = false;
    std::string name;
    std::uint32_t length = 0;  ///< DLC in bytes (up to 64 for CAN FD)
    std::string transmitter;
    std::vector<Signal> signals;
    std::string comment;
    std::map<std::string, AttributeValue> attributes;
    bool is_fd = false;  ///< length > 8, or VFrameFormat names a CAN FD format

    [[nodiscard]] const Signal* find_signal(std::string_view name) const;
    /// Index in `signals`; throws CanError naming the message and the signal when absent.
    [[nodiscard]] std::size_t signal_index(std::string_view name) const;
    /// True when the signal is present in this payload (multiplexing resolved).
    [[nodiscard]] bool is_active(const Signal& s, const std::uint8_t* data) const;
    /// Decodes every active signal. Returns false with `error` set when the payload is shorter
    /// than the message needs (a run-time condition on a bus, not an exception).
    [[nodiscard]] bool decode(const std::uint8_t* data, std::size_t len, std::vector<DecodedSignal>& out,
                              std::string* error = nullptr) const;
    /// Encodes physical values by signal name into `length` bytes; unnamed signals are raw 0.
    /// Throws CanError on an unknown name, an unrepresentable value or a multiplexed signal
    /// whose switch value does not select it.
    [[nodiscard]] std::vector<std::uint8_t> encode(const std::vector<std::pair<std::string, double>>& values) const;
    /// A frame with this message's id, flags and encoded payload.
    [[nodiscard]] CanFrame encode_frame(const std::vector<std::pair<std::string, double>>& values) const;
    /// Attribute value (message attribute, else the definition's default), if any.
    [[nodiscard]] std::optional<double> cycle_time_ms() const { return cycle_time_ms_; }

    std::optional<double> cycle_time_ms_;  ///< GenMsgCycleTime resolved against defaults
};

struct Database {
    std::string version;
    /// Lenient parsing only: "file:line:col: what; what was skipped or kept", in file order (at
    /// most kDbcMaxReportedProblems, then one line saying how many more).
    std::vector<std::string> warnings;
    std::vector<std::string> nodes;
    std::map<std::string, std::string> node_comments;
    std::vector<Message> messages;
    std::map<std::string, AttributeDefinition> attribute_definitions;
    std::map<std::string, AttributeValue> network_attributes;
    std::map<std::string, std::map<std::int64_t, std::string>> value_tables;  ///< VAL_TABLE_

    [[nodiscard]] const Message* find_message(std::uint32_t id, bool extended) const;
    [[nodiscard]] const Message* find_message(std::string_view name) const;
    /// Throws CanError naming the message when absent.
    [[nodiscard]] const Message& message(std::string_view name) const;
};

/// Limits of the DBC parser (docs/limits.md): the file size, the messages and signals it holds,
/// and the problems listed in one error (all are counted). Past a message or signal limit parsing
/// stops with a problem naming the limit.
inline constexpr std::size_t kDbcMaxBytes = std::size_t{8} << 20;
inline constexpr std::size_t kDbcMaxMessages = 8192;
inline constexpr std::size_t kDbcMaxSignalsPerMessage = 1024;
inline constexpr std::size_t kDbcMaxSignals = 100'000;
inline constexpr std::size_t kDbcMaxReportedProblems = 100;

enum class DbcMode {
    Lenient,  ///< as cantools strict=False: recoverable problems are warnings (Database::warnings)
    Strict,   ///< every problem refuses the file
};

/// Parses DBC text; `file_name` is used in messages. Throws CanError listing every problem. In both
/// modes a malformed statement, an out-of-range frame id or length, and multiplexing that cannot be
/// evaluated (a signal multiplexed by itself, a cycle of multiplexors, a multiplexor not in the
/// message) refuse the file. Signal and message long names (the SystemSignalLongSymbol and
/// SystemMessageLongSymbol attributes CANdb++ writes, else ...LongName) replace the names cut to 32
/// characters, as cantools does.
[[nodiscard]] Database parse_dbc(std::string_view text, const std::string& file_name, DbcMode mode = DbcMode::Lenient);
[[nodiscard]] Database parse_dbc_file(const std::string& path, DbcMode mode = DbcMode::Lenient);

}  // namespace emadiag::can
