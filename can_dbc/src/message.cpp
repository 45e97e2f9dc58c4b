#include "emadiag/can/can_error.hpp"
#include "emadiag/can/dbc.hpp"

#include <fstream>
#include <sstream>

namespace emadiag::can {

const Signal* Message::find_signal(std::string_view signal_name) const {
    for (const auto& s : signals)
        if (s.name == signal_name) return &s;
    return nullptr;
}

std::size_t Message::signal_index(std::string_view signal_name) const {
    for (std::size_t i = 0; i < signals.size(); ++i)
        if (signals[i].name == signal_name) return i;
    throw CanError("message '" + name + "' (" + format_id(id, extended) + ") has no signal '" + std::string(signal_name) + "'");
}

bool Message::is_active(const Signal& s, const std::uint8_t* data) const {
    if (s.mux_role == MuxRole::None || s.mux_role == MuxRole::Multiplexor) return true;
    const Signal* sw = find_signal(s.multiplexor);
    if (sw == nullptr || !is_active(*sw, data)) return false;
    const std::uint64_t v = sw->extract_raw(data);
    for (const auto& r : s.mux_ranges)
        if (v >= r.lo && v <= r.hi) return true;
    return false;
}

bool Message::decode(const std::uint8_t* data, std::size_t len, std::vector<DecodedSignal>& out, std::string* error) const {
    out.clear();
    if (len < length) {
        if (error) *error = "message '" + name + "' (" + format_id(id, extended) + ") needs " + std::to_string(length) +
                            " bytes, frame has " + std::to_string(len);
        return false;
    }
    for (const auto& s : signals) {
        if (!is_active(s, data)) continue;
        const std::uint64_t raw = s.extract_raw(data);
        out.push_back(DecodedSignal{&s, raw, s.raw_to_physical(raw)});
    }
    return true;
}

std::vector<std::uint8_t> Message::encode(const std::vector<std::pair<std::string, double>>& values) const {
    std::vector<std::uint8_t> data(length, 0);
    for (const auto& [sig_name, value] : values) {
        const Signal* s = find_signal(sig_name);
        if (s == nullptr)
            throw CanError("message '" + name + "' (" + format_id(id, extended) + ") has no signal '" + sig_name + "'");
        s->insert_raw(s->physical_to_raw(value), data.data());
    }
    for (const auto& [sig_name, value] : values) {
        const Signal* s = find_signal(sig_name);
        if (!is_active(*s, data.data()))
            throw CanError("message '" + name + "': signal '" + sig_name + "' is multiplexed by '" + s->multiplexor +
                           "', whose encoded value does not select it");
    }
    return data;
}

CanFrame Message::encode_frame(const std::vector<std::pair<std::string, double>>& values) const {
    CanFrame f;
    f.id = id;
    f.extended = extended;
    f.fd = is_fd;
    f.len = static_cast<std::uint8_t>(length);
    const auto bytes = encode(values);
    std::copy(bytes.begin(), bytes.end(), f.data.begin());
    return f;
}

const Message* Database::find_message(std::uint32_t msg_id, bool extended) const {
    for (const auto& m : messages)
        if (m.id == msg_id && m.extended == extended) return &m;
    return nullptr;
}

const Message* Database::find_message(std::string_view msg_name) const {
    for (const auto& m : messages)
        if (m.name == msg_name) return &m;
    return nullptr;
}

const Message& Database::message(std::string_view msg_name) const {
    const Message* m = find_message(msg_name);
    if (m == nullptr) throw CanError("the database has no message '" + std::string(msg_name) + "'");
    return *m;
}

Database parse_dbc_file(const std::string& path, DbcMode mode) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw CanError(path + ": cannot open the DBC file");
    std::string text;
    char buf[65536];
    while (in.read(buf, sizeof buf) || in.gcount() > 0) {
        text.append(buf, static_cast<std::size_t>(in.gcount()));
        if (text.size() > kDbcMaxBytes) {
            throw CanError(path + ": larger than the limit kDbcMaxBytes = " + std::to_string(kDbcMaxBytes) + " for a DBC file");
        }
    }
    if (in.bad()) throw CanError(path + ": read error");
    return parse_dbc(text, path, mode);
}

}  // namespace emadiag::can
