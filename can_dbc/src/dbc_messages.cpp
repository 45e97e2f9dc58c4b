// DBC parser, the messages: BO_ and its SG_ signals (with their limits), and CM_ comments.
#include "dbc_parser.hpp"

#include "emadiag/can/can_frame.hpp"

#include <cctype>

namespace emadiag::can::detail {

void Parser::message() {
    const Token kw = next();
    const Token id_tok = peek();
    const std::uint64_t raw_id = unsigned_int("message id");
    const std::string name = ident("message name");
    expect_punct(":");
    const Token dlc_tok = peek();
    const std::uint64_t dlc = unsigned_int("message length");
    const std::string transmitter = ident("transmitter node");
    current_ = nullptr;
    if (name == "VECTOR__INDEPENDENT_SIG_MSG") {  // CANdb++ pseudo-message for unattached signals
        ignore_signals_ = true;
        placeholder_ids_.insert(raw_id);
        return;
    }
    ignore_signals_ = false;
    Message m;
    m.extended = (raw_id & kDbcExtendedFlag) != 0;
    m.id = static_cast<std::uint32_t>(raw_id & ~std::uint64_t{kDbcExtendedFlag});
    m.name = name;
    m.transmitter = transmitter;
    bool ok = true;
    if (raw_id > 0xFFFFFFFFull || (m.extended && m.id > kExtendedIdMask) || (!m.extended && m.id > kStandardIdMask)) {
        error(id_tok, "message '" + name + "': id " + std::to_string(raw_id) + " is out of range (standard ids up to 2047; extended ids need bit 31 set and at most 0x1FFFFFFF)");
        ok = false;
    }
    if (dlc > kFdMaxLen) {
        error(dlc_tok, "message '" + name + "': length " + std::to_string(dlc) + " bytes is not a CAN or CAN FD length (0-8, 12, 16, 20, 24, 32, 48, 64)");
        ok = false;
    } else if (!is_valid_fd_len(dlc)) {  // J1939 transport-protocol messages (10, 15, 19 ... bytes)
        soft(dlc_tok, "message '" + name + "': length " + std::to_string(dlc) + " bytes is not a CAN or CAN FD length (0-8, 12, 16, 20, 24, 32, 48, 64)",
             "kept: decoded from a payload of " + std::to_string(dlc) + " bytes (a transport-protocol message)");
    }
    m.length = static_cast<std::uint32_t>(dlc);
    m.is_fd = dlc > kClassicMaxLen;
    if (ok && db_.find_message(m.id, m.extended)) {
        soft(id_tok, "message '" + name + "': id " + format_id(m.id, m.extended) + " is already used by message '" + db_.find_message(m.id, m.extended)->name + "'",
             "message '" + name + "' and its signals skipped");
        if (mode_ == DbcMode::Lenient) {
            ignore_signals_ = true;
            return;
        }
    }
    if (db_.messages.size() >= kDbcMaxMessages) {
        throw LimitExceeded{kw.line, kw.col, "more than the limit kDbcMaxMessages = " + std::to_string(kDbcMaxMessages) + " messages"};
    }
    message_pos_[m.name] = id_tok;
    db_.messages.push_back(std::move(m));
    current_ = &db_.messages.back();
    current_ok_ = ok;
}

void Parser::signal() {
    const Token kw = next();
    Signal s;
    const Token name_tok = peek();
    s.name = ident("signal name");
    if (peek().kind == Tok::Ident) {  // multiplexer indicator: M, mN, mNM
        const Token mt = next();
        const std::string& m = mt.text;
        if (m == "M") {
            s.mux_role = MuxRole::Multiplexor;
        } else if (m == "m") {  // no value: cantools' lenient mode reads the signal as a plain one
            soft(mt, "multiplexer indicator 'm' without a value for signal '" + s.name + "'", "read as a plain signal");
        } else if (m.size() >= 2 && m[0] == 'm' && std::isdigit(static_cast<unsigned char>(m[1]))) {
            std::size_t j = 1;
            while (j < m.size() && std::isdigit(static_cast<unsigned char>(m[j]))) ++j;
            if (!parse_decimal_u64(std::string_view(m).substr(1, j - 1), s.mux_value))
                throw SyntaxError{mt.line, mt.col, "multiplexer value in '" + m + "' is out of range (at most 2^64 - 1)"};
            const std::string rest = m.substr(j);
            if (rest == "M") s.mux_role = MuxRole::MultiplexedMultiplexor;
            else if (rest.empty()) s.mux_role = MuxRole::Multiplexed;
            else throw SyntaxError{mt.line, mt.col, "invalid multiplexer indicator '" + m + "' (expected M, mN or mNM)"};
            s.mux_ranges.push_back(MuxRange{s.mux_value, s.mux_value});
        } else {
            throw SyntaxError{mt.line, mt.col, "invalid multiplexer indicator '" + m + "' (expected M, mN or mNM)"};
        }
    }
    expect_punct(":");
    const Token start_tok = peek();
    const std::uint64_t start = unsigned_int("start bit");
    expect_punct("|");
    const Token len_tok = peek();
    const std::uint64_t len = unsigned_int("signal length");
    expect_punct("@");
    const Token order_tok = peek();
    if (order_tok.kind != Tok::Number || (order_tok.text != "0" && order_tok.text != "1"))
        fail(order_tok, "byte order 0 (big-endian) or 1 (little-endian)");
    next();
    s.byte_order = order_tok.text == "1" ? ByteOrder::LittleEndian : ByteOrder::BigEndian;
    const Token sign_tok = peek();
    if (sign_tok.kind != Tok::Punct || (sign_tok.text != "+" && sign_tok.text != "-")) fail(sign_tok, "'+' (unsigned) or '-' (signed)");
    next();
    s.is_signed = sign_tok.text == "-";
    expect_punct("(");
    s.factor = number("factor");
    expect_punct(",");
    s.offset = number("offset");
    expect_punct(")");
    expect_punct("[");
    s.minimum = limit_number("minimum");
    expect_punct("|");
    s.maximum = limit_number("maximum");
    expect_punct("]");
    s.unit = string_lit("unit string");
    while (peek().kind == Tok::Ident && !(peek().line_start && keywords().count(peek().text))) {
        s.receivers.push_back(next().text);
        accept_punct(",");
    }
    if (ignore_signals_) return;
    if (current_ == nullptr) {
        error(kw, "SG_ '" + s.name + "' outside a BO_ message");
        return;
    }
    if (s.factor == 0.0) error(name_tok, "signal '" + s.name + "': factor must not be zero");
    if (start >= kFdMaxLen * 8) {
        error(start_tok, "signal '" + s.name + "': start bit " + std::to_string(start) + " is beyond 511");
        return;
    }
    if (len == 0) {
        error(len_tok, "signal '" + s.name + "': length 0 bits; allowed 1 to 64");
        return;
    }
    if (len > 64) {
        soft(len_tok, "signal '" + s.name + "': length " + std::to_string(len) + " bits; allowed 1 to 64", "signal skipped");
        return;
    }
    s.start_bit = static_cast<std::uint32_t>(start);
    s.length = static_cast<std::uint32_t>(len);
    if (current_->signals.size() >= kDbcMaxSignalsPerMessage) {
        throw LimitExceeded{kw.line, kw.col, "message '" + current_->name + "' has more than the limit kDbcMaxSignalsPerMessage = " +
                                                 std::to_string(kDbcMaxSignalsPerMessage) + " signals"};
    }
    if (++signal_count_ > kDbcMaxSignals) {
        throw LimitExceeded{kw.line, kw.col, "more than the limit kDbcMaxSignals = " + std::to_string(kDbcMaxSignals) + " signals"};
    }
    if (current_->find_signal(s.name)) {
        soft(name_tok, "signal '" + s.name + "' is defined twice in message '" + current_->name + "'", "the second one skipped");
        return;
    }
    if (current_ok_) {
        if (auto e = s.compute_layout(current_->length)) {
            soft(start_tok, *e + " ('" + current_->name + "')", "signal '" + s.name + "' skipped");
            return;
        }
    }
    current_->signals.push_back(std::move(s));
    signal_pos_[current_->name + "." + current_->signals.back().name] = name_tok;
}

Message* Parser::message_by_id(const Token& at, std::uint64_t raw_id) {
    const bool ext = (raw_id & kDbcExtendedFlag) != 0;
    const auto id = static_cast<std::uint32_t>(raw_id & ~std::uint64_t{kDbcExtendedFlag});
    for (auto& m : db_.messages)
        if (m.id == id && m.extended == ext) return &m;
    if (placeholder_ids_.count(raw_id))
        soft(at, "message id " + std::to_string(raw_id) + " is CANdb++'s placeholder VECTOR__INDEPENDENT_SIG_MSG (signals in no message)",
             "statement skipped");
    else soft(at, "unknown message id " + std::to_string(raw_id), "statement skipped");
    return nullptr;
}

Signal* Parser::signal_of(Message* m, const Token& at, const std::string& name) {
    if (m == nullptr) return nullptr;
    for (auto& s : m->signals)
        if (s.name == name) return &s;
    soft(at, "message '" + m->name + "' has no signal '" + name + "'", "statement skipped");
    return nullptr;
}

void Parser::comment() {
    next();
    const Token& t = peek();
    if (t.kind == Tok::String) {
        db_.network_attributes["__comment"] = AttributeValue{true, 0, next().text};
        expect_semicolon();
        return;
    }
    const std::string what = ident("BU_, BO_, SG_, EV_ or a comment string");
    if (what == "BU_") {
        const std::string node = ident("node name");
        db_.node_comments[node] = string_lit("comment string");
    } else if (what == "BO_") {
        const Token at = peek();
        const auto id = unsigned_int("message id");
        const std::string text = string_lit("comment string");
        if (Message* m = message_by_id(at, id)) m->comment = text;
    } else if (what == "SG_") {
        const Token at = peek();
        const auto id = unsigned_int("message id");
        const Token sat = peek();
        const std::string sname = ident("signal name");
        const std::string text = string_lit("comment string");
        if (Signal* s = signal_of(message_by_id(at, id), sat, sname)) s->comment = text;
    } else if (what == "EV_") {
        ident("environment variable name");
        string_lit("comment string");
    } else {
        throw SyntaxError{t.line, t.col, "expected BU_, BO_, SG_ or EV_ after CM_, found '" + what + "'"};
    }
    expect_semicolon();
}

}  // namespace emadiag::can::detail
