// DBC parser: a tokenizer with line:col positions, then one function per keyword.
// Every problem is collected as "file:line:col: message"; after an error the parser resumes at the
// next keyword that starts a line, so one pass reports all problems.
#include "emadiag/can/can_error.hpp"
#include "emadiag/can/dbc.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <set>

namespace emadiag::can {
namespace {

enum class Tok { Ident, Number, String, Punct, End };

struct Token {
    Tok kind = Tok::End;
    std::string text;
    int line = 0;
    int col = 0;
    bool line_start = false;  ///< first token on its line
};

struct SyntaxError {
    int line;
    int col;
    std::string message;
};

const std::set<std::string>& keywords() {
    static const std::set<std::string> k = {
        "VERSION", "NS_", "BS_", "BU_", "BO_", "SG_", "CM_", "BA_DEF_", "BA_DEF_DEF_", "BA_", "VAL_", "VAL_TABLE_",
        "SIG_VALTYPE_", "SG_MUL_VAL_", "BO_TX_BU_", "EV_", "ENVVAR_DATA_", "SGTYPE_", "SGTYPE_VAL_", "BA_DEF_SGTYPE_",
        "BA_SGTYPE_", "SIG_TYPE_REF_", "SIG_GROUP_", "SIGTYPE_VALTYPE_", "BA_DEF_REL_", "BA_REL_", "BA_DEF_DEF_REL_",
        "CAT_DEF_", "CAT_", "FILTER", "BU_SG_REL_", "BU_EV_REL_", "BU_BO_REL_", "SG_MUL_VAL_", "VAL_TABLE_"};
    return k;
}
/// Keywords accepted and skipped (they carry nothing this library uses).
const std::set<std::string>& skipped_keywords() {
    static const std::set<std::string> k = {"BO_TX_BU_", "EV_", "ENVVAR_DATA_", "SGTYPE_", "SGTYPE_VAL_",
                                            "BA_DEF_SGTYPE_", "BA_SGTYPE_", "SIG_TYPE_REF_", "SIG_GROUP_",
                                            "SIGTYPE_VALTYPE_", "BA_DEF_REL_", "BA_REL_", "BA_DEF_DEF_REL_",
                                            "CAT_DEF_", "CAT_", "FILTER", "BU_SG_REL_", "BU_EV_REL_", "BU_BO_REL_"};
    return k;
}

/// Decimal digits only, no sign, no overflow.
bool parse_decimal_u64(std::string_view digits, std::uint64_t& out) {
    if (digits.empty()) return false;
    const auto [ptr, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), out);
    return ec == std::errc() && ptr == digits.data() + digits.size();
}

/// A limit of docs/limits.md was exceeded: parsing stops (the problems so far are reported).
struct LimitExceeded {
    int line;
    int col;
    std::string message;
};

class Parser {
public:
    Parser(std::string_view text, std::string file, DbcMode mode) : text_(text), file_(std::move(file)), mode_(mode) {}

    Database run() {
        try {
            tokenize();
            while (peek().kind != Tok::End) {
                const std::size_t start = pos_;
                try {
                    statement();
                } catch (const SyntaxError& e) {
                    error(e.line, e.col, e.message);
                    recover(start);
                }
            }
            finish();
        } catch (const LimitExceeded& e) {
            // Listed even when the problem list is full: the reader must learn which limit stopped it.
            errors_.push_back(Problem{e.line, e.col, file_ + ":" + std::to_string(e.line) + ":" + std::to_string(e.col) + ": " +
                                                         e.message + "; parsing stopped here"});
        }
        if (!errors_.empty() || dropped_errors_ > 0) {
            const std::size_t n = errors_.size() + dropped_errors_;
            std::string all = std::to_string(n) + (n == 1 ? " problem" : " problems") + " in " + file_ +
                              (dropped_errors_ > 0 ? " (the first " + std::to_string(errors_.size()) + " listed)" : "") + ":";
            std::stable_sort(errors_.begin(), errors_.end(), [](const Problem& a, const Problem& b) {
                return a.line != b.line ? a.line < b.line : a.col < b.col;
            });
            for (const auto& e : errors_) all += "\n" + e.text;
            throw CanError(all);
        }
        std::stable_sort(warnings_.begin(), warnings_.end(), [](const Problem& a, const Problem& b) {
            return a.line != b.line ? a.line < b.line : a.col < b.col;
        });
        for (auto& w : warnings_) db_.warnings.push_back(std::move(w.text));
        if (dropped_warnings_ > 0) db_.warnings.push_back(file_ + ": " + std::to_string(dropped_warnings_) + " more warnings not listed");
        return std::move(db_);
    }

private:
    // ---------------------------------------------------------------- tokenizer
    void tokenize() {
        int line = 1, col = 1;
        bool at_line_start = true;
        std::size_t i = 0;
        auto advance = [&](std::size_t n) {
            for (std::size_t k = 0; k < n; ++k, ++i) {
                if (text_[i] == '\n') {
                    ++line;
                    col = 1;
                    at_line_start = true;
                } else {
                    ++col;
                }
            }
        };
        while (i < text_.size()) {
            const char c = text_[i];
            if (c == '\n' || c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
                advance(1);
                continue;
            }
            if (c == '/' && i + 1 < text_.size() && text_[i + 1] == '/') {  // line comment (accepted by cantools)
                while (i < text_.size() && text_[i] != '\n') advance(1);
                continue;
            }
            Token t;
            t.line = line;
            t.col = col;
            t.line_start = at_line_start;
            at_line_start = false;
            if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
                std::size_t j = i;
                while (j < text_.size() && (std::isalnum(static_cast<unsigned char>(text_[j])) || text_[j] == '_')) ++j;
                t.kind = Tok::Ident;
                t.text = std::string(text_.substr(i, j - i));
                advance(j - i);
            } else if (std::isdigit(static_cast<unsigned char>(c)) ||
                       ((c == '-' || c == '+' || c == '.') && i + 1 < text_.size() &&
                        (std::isdigit(static_cast<unsigned char>(text_[i + 1])) || text_[i + 1] == '.'))) {
                std::size_t j = i + 1;
                while (j < text_.size()) {
                    const char d = text_[j];
                    if (std::isalnum(static_cast<unsigned char>(d)) || d == '.' ||
                        ((d == '-' || d == '+') && (text_[j - 1] == 'e' || text_[j - 1] == 'E') &&
                         text_.substr(i, 2) != "0x")) {
                        ++j;
                    } else {
                        break;
                    }
                }
                t.kind = Tok::Number;
                t.text = std::string(text_.substr(i, j - i));
                advance(j - i);
            } else if (c == '"') {
                std::string s;
                std::size_t j = i + 1;
                bool closed = false;
                while (j < text_.size()) {
                    if (text_[j] == '\\' && j + 1 < text_.size()) {
                        s += text_[j + 1];
                        j += 2;
                        continue;
                    }
                    if (text_[j] == '"') {
                        closed = true;
                        break;
                    }
                    s += text_[j++];
                }
                if (!closed) {
                    error(t.line, t.col, "unterminated string");
                    advance(text_.size() - i);
                    break;
                }
                t.kind = Tok::String;
                t.text = std::move(s);
                advance(j + 1 - i);
            } else if (std::string_view(":;|@()[],+-").find(c) != std::string_view::npos) {
                t.kind = Tok::Punct;
                t.text = std::string(1, c);
                advance(1);
            } else {
                error(t.line, t.col, std::string("unexpected character '") + c + "'");
                advance(1);
                continue;
            }
            toks_.push_back(std::move(t));
        }
        Token end;
        end.kind = Tok::End;
        end.line = line;
        end.col = col;
        end.line_start = true;
        toks_.push_back(end);
    }

    // ---------------------------------------------------------------- helpers
    const Token& peek(std::size_t ahead = 0) const { return toks_[std::min(pos_ + ahead, toks_.size() - 1)]; }
    const Token& next() {
        const Token& t = toks_[pos_];
        if (pos_ + 1 < toks_.size()) ++pos_;
        return t;
    }
    static std::string describe(const Token& t) {
        switch (t.kind) {
            case Tok::End: return "end of file";
            case Tok::String: return "string \"" + t.text + "\"";
            default: return "'" + t.text + "'";
        }
    }
    [[noreturn]] static void fail(const Token& t, const std::string& what) {
        throw SyntaxError{t.line, t.col, "expected " + what + ", found " + describe(t)};
    }
    void error(int line, int col, const std::string& message) {
        if (errors_.size() >= kDbcMaxReportedProblems) {
            ++dropped_errors_;
            return;
        }
        errors_.push_back(Problem{line, col, file_ + ":" + std::to_string(line) + ":" + std::to_string(col) + ": " + message});
    }
    void error(const Token& t, const std::string& message) { error(t.line, t.col, message); }
    /// A problem cantools' lenient mode lets pass: an error in strict mode, else a warning that says
    /// what was skipped or kept.
    void soft(int line, int col, const std::string& message, const std::string& outcome) {
        if (mode_ == DbcMode::Strict) {
            error(line, col, message);
            return;
        }
        if (warnings_.size() >= kDbcMaxReportedProblems) {
            ++dropped_warnings_;
            return;
        }
        warnings_.push_back(Problem{line, col, file_ + ":" + std::to_string(line) + ":" + std::to_string(col) + ": " + message + "; " + outcome});
    }
    void soft(const Token& t, const std::string& message, const std::string& outcome) { soft(t.line, t.col, message, outcome); }

    void expect_punct(const char* p) {
        const Token& t = peek();
        if (t.kind != Tok::Punct || t.text != p) fail(t, std::string("'") + p + "'");
        next();
    }
    bool accept_punct(const char* p) {
        if (peek().kind == Tok::Punct && peek().text == p) {
            next();
            return true;
        }
        return false;
    }
    std::string ident(const char* what) {
        const Token& t = peek();
        if (t.kind != Tok::Ident) fail(t, what);
        return next().text;
    }
    std::string string_lit(const char* what) {
        const Token& t = peek();
        if (t.kind != Tok::String) fail(t, what);
        return next().text;
    }
    double number(const char* what) {
        const Token& t = peek();
        if (t.kind != Tok::Number) fail(t, what);
        errno = 0;
        char* end = nullptr;
        const double v = std::strtod(t.text.c_str(), &end);
        if (end != t.text.c_str() + t.text.size() || errno == ERANGE)
            throw SyntaxError{t.line, t.col, std::string("invalid number '") + t.text + "' for " + what};
        next();
        return v;
    }
    /// A signal's minimum or maximum: lenient reading keeps a value beyond the double range as
    /// +-infinity (or 0), as cantools does, with a warning; it is never used to scale a value.
    double limit_number(const char* what) {
        const Token& t = peek();
        if (t.kind != Tok::Number || mode_ == DbcMode::Strict) return number(what);
        errno = 0;
        char* end = nullptr;
        const double v = std::strtod(t.text.c_str(), &end);
        if (end != t.text.c_str() + t.text.size()) return number(what);
        if (errno == ERANGE) soft(t, std::string("number '") + t.text + "' for " + what + " is beyond the double range", "kept as " + std::to_string(v));
        next();
        return v;
    }
    /// A value-description key (VAL_, VAL_TABLE_): a whole number that fits a signed 64-bit raw value.
    std::int64_t value_key(const char* what) {
        const Token t = peek();
        const double v = number(what);
        // 2^63 is exact in a double; every whole double in [-2^63, 2^63) converts.
        constexpr double kTwo63 = 9223372036854775808.0;
        if (!(v == std::trunc(v) && v >= -kTwo63 && v < kTwo63))
            throw SyntaxError{t.line, t.col, std::string("invalid ") + what + " '" + t.text + "': not a whole number of a signed 64-bit raw value"};
        return static_cast<std::int64_t>(v);
    }
    std::uint64_t unsigned_int(const char* what) {
        const Token& t = peek();
        if (t.kind != Tok::Number || t.text[0] == '-' || t.text[0] == '+') fail(t, std::string("unsigned integer ") + what);
        errno = 0;
        char* end = nullptr;
        const unsigned long long v = std::strtoull(t.text.c_str(), &end, 10);
        if (end != t.text.c_str() + t.text.size() || errno == ERANGE)
            throw SyntaxError{t.line, t.col, std::string("invalid unsigned integer '") + t.text + "' for " + what};
        next();
        return v;
    }
    void expect_semicolon() {
        if (peek().kind == Tok::End && mode_ == DbcMode::Lenient) {  // cantools accepts a last statement without it
            soft(peek(), "expected ';' at the end of the file", "statement kept");
            return;
        }
        expect_punct(";");
    }

    /// Skips to the next keyword that starts a line (after an error in the statement at `start`).
    void recover(std::size_t start) {
        if (pos_ <= start) pos_ = start + 1;
        while (peek().kind != Tok::End) {
            const Token& t = peek();
            if (t.line_start && t.kind == Tok::Ident && keywords().count(t.text)) return;
            next();
        }
    }
    /// Skips a statement that ends with ';'.
    void skip_to_semicolon() {
        while (peek().kind != Tok::End) {
            if (next().text == ";" ) return;
        }
    }
    /// Skips tokens until one that starts a line at column 1 (NS_ and BS_ blocks).
    void skip_block() {
        while (peek().kind != Tok::End && !(peek().line_start && peek().col == 1)) next();
    }

    // ---------------------------------------------------------------- statements
    void statement() {
        const Token& t = peek();
        if (t.kind != Tok::Ident) fail(t, "a keyword");
        const std::string kw = t.text;
        if (kw == "VERSION") {
            next();
            db_.version = string_lit("version string");
        } else if (kw == "NS_" || kw == "BS_") {
            next();
            expect_punct(":");
            skip_block();
        } else if (kw == "BU_") {
            next();
            expect_punct(":");
            while (peek().kind == Tok::Ident && !(peek().line_start && keywords().count(peek().text)))
                db_.nodes.push_back(next().text);
        } else if (kw == "VAL_TABLE_") {
            next();
            const std::string name = ident("value table name");
            auto& table = db_.value_tables[name];
            while (peek().kind == Tok::Number) {
                const std::int64_t v = value_key("value");
                table[v] = string_lit("value description");
            }
            expect_semicolon();
        } else if (kw == "BO_") {
            message();
        } else if (kw == "SG_") {
            signal();
        } else if (kw == "CM_") {
            comment();
        } else if (kw == "BA_DEF_") {
            attribute_definition();
        } else if (kw == "BA_DEF_DEF_") {
            attribute_default();
        } else if (kw == "BA_") {
            attribute_value();
        } else if (kw == "VAL_") {
            value_descriptions();
        } else if (kw == "SIG_VALTYPE_") {
            signal_value_type();
        } else if (kw == "SG_MUL_VAL_") {
            extended_multiplexing();
        } else if (skipped_keywords().count(kw)) {
            next();
            skip_to_semicolon();
        } else {
            throw SyntaxError{t.line, t.col, "unknown keyword '" + kw + "'"};
        }
    }

    void message() {
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

    void signal() {
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

    Message* message_by_id(const Token& at, std::uint64_t raw_id) {
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
    Signal* signal_of(Message* m, const Token& at, const std::string& name) {
        if (m == nullptr) return nullptr;
        for (auto& s : m->signals)
            if (s.name == name) return &s;
        soft(at, "message '" + m->name + "' has no signal '" + name + "'", "statement skipped");
        return nullptr;
    }

    void comment() {
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

    void attribute_definition() {
        next();
        AttributeDefinition d;
        if (peek().kind == Tok::Ident) {
            const Token ot = next();
            if (ot.text == "BU_") d.object = AttributeObject::Node;
            else if (ot.text == "BO_") d.object = AttributeObject::Message;
            else if (ot.text == "SG_") d.object = AttributeObject::Signal;
            else if (ot.text == "EV_") d.object = AttributeObject::EnvVar;
            else throw SyntaxError{ot.line, ot.col, "expected BU_, BO_, SG_, EV_ or the attribute name, found '" + ot.text + "'"};
        }
        const Token name_tok = peek();
        d.name = string_lit("attribute name");
        const Token tt = peek();
        const std::string type = ident("attribute type INT, HEX, FLOAT, STRING or ENUM");
        if (type == "INT" || type == "HEX" || type == "FLOAT") {
            d.type = type == "INT" ? AttributeType::Int : type == "HEX" ? AttributeType::Hex : AttributeType::Float;
            d.minimum = number("attribute minimum");
            d.maximum = number("attribute maximum");
        } else if (type == "STRING") {
            d.type = AttributeType::String;
        } else if (type == "ENUM") {
            d.type = AttributeType::Enum;
            d.enum_values.push_back(string_lit("enum value"));
            while (accept_punct(",")) d.enum_values.push_back(string_lit("enum value"));
        } else {
            throw SyntaxError{tt.line, tt.col, "attribute '" + d.name + "': unknown type '" + type + "' (expected INT, HEX, FLOAT, STRING or ENUM)"};
        }
        expect_semicolon();
        if (db_.attribute_definitions.count(d.name)) soft(name_tok, "attribute '" + d.name + "' is defined twice", "the later definition kept");
        db_.attribute_definitions[d.name] = std::move(d);
    }

    /// Reads an attribute value token (number or string) and checks it against the definition.
    struct Literal {
        AttributeValue value;
        bool skip = false;  ///< lenient: not stored (a warning said so)
    };
    Literal attribute_literal(const AttributeDefinition* def, const Token& at) {
        Literal lit;
        AttributeValue& v = lit.value;
        bool& skip = lit.skip;
        if (peek().kind == Tok::String) {
            v.is_string = true;
            v.text = next().text;
        } else {
            v.number = number("attribute value");
            v.text = at.text;
        }
        if (def == nullptr) {
            skip = true;
            return lit;
        }
        const bool numeric = def->type == AttributeType::Int || def->type == AttributeType::Hex || def->type == AttributeType::Float;
        if (numeric && v.is_string) {
            soft(at, "attribute '" + def->name + "' is numeric, found string \"" + v.text + "\"", "kept as a string");
        } else if (def->type == AttributeType::String && !v.is_string) {
            soft(at, "attribute '" + def->name + "' is a STRING, found number " + at.text, "kept as a number");
        } else if (numeric && (def->minimum != 0 || def->maximum != 0) && (v.number < def->minimum || v.number > def->maximum)) {
            soft(at, "attribute '" + def->name + "': value " + at.text + " outside [" + std::to_string(def->minimum) + ", " + std::to_string(def->maximum) + "]",
                 "kept as written");
        } else if (def->type == AttributeType::Enum) {
            if (v.is_string) {
                bool found = false;
                for (std::size_t i = 0; i < def->enum_values.size(); ++i)
                    if (def->enum_values[i] == v.text) {
                        v.number = static_cast<double>(i);
                        found = true;
                    }
                if (!found) {
                    soft(at, "attribute '" + def->name + "': \"" + v.text + "\" is not one of its ENUM values", "value skipped");
                    skip = true;
                }
            } else if (v.number < 0 || v.number >= static_cast<double>(def->enum_values.size())) {
                soft(at, "attribute '" + def->name + "': ENUM index " + at.text + " outside 0.." + std::to_string(def->enum_values.size() - 1),
                     "value skipped");
                skip = true;
            } else {
                v.text = def->enum_values[static_cast<std::size_t>(v.number)];
            }
        }
        return lit;
    }

    void attribute_default() {
        next();
        const Token nt = peek();
        const std::string name = string_lit("attribute name");
        auto it = db_.attribute_definitions.find(name);
        if (it == db_.attribute_definitions.end()) soft(nt, "BA_DEF_DEF_ for undefined attribute '" + name + "'", "statement skipped");
        const Token vt = peek();
        Literal v = attribute_literal(it == db_.attribute_definitions.end() ? nullptr : &it->second, vt);
        expect_semicolon();
        if (it != db_.attribute_definitions.end() && !v.skip) it->second.default_value = v.value;
    }

    void attribute_value() {
        next();
        const Token nt = peek();
        const std::string name = string_lit("attribute name");
        auto it = db_.attribute_definitions.find(name);
        const AttributeDefinition* def = it == db_.attribute_definitions.end() ? nullptr : &it->second;
        if (def == nullptr) soft(nt, "BA_ for undefined attribute '" + name + "'", "statement skipped");
        std::map<std::string, AttributeValue>* target = &db_.network_attributes;
        AttributeObject object = AttributeObject::Network;
        std::map<std::string, AttributeValue> discard;
        if (peek().kind == Tok::Ident) {
            const std::string what = next().text;
            if (what == "BU_") {
                object = AttributeObject::Node;
                ident("node name");
                target = &discard;
            } else if (what == "BO_") {
                object = AttributeObject::Message;
                const Token at = peek();
                Message* m = message_by_id(at, unsigned_int("message id"));
                target = m ? &m->attributes : &discard;
            } else if (what == "SG_") {
                object = AttributeObject::Signal;
                const Token at = peek();
                Message* m = message_by_id(at, unsigned_int("message id"));
                const Token sat = peek();
                Signal* s = signal_of(m, sat, ident("signal name"));
                target = s ? &s->attributes : &discard;
            } else if (what == "EV_") {
                object = AttributeObject::EnvVar;
                ident("environment variable name");
                target = &discard;
            } else {
                fail(nt, "BU_, BO_, SG_ or EV_");
            }
        }
        if (def != nullptr && def->object != object) {
            soft(nt, "attribute '" + name + "' is not defined for this kind of object", "statement skipped");
            target = &discard;
        }
        const Token vt = peek();
        Literal v = attribute_literal(def, vt);
        expect_semicolon();
        if (def != nullptr && !v.skip) (*target)[name] = v.value;
    }

    void value_descriptions() {
        next();
        if (peek().kind == Tok::Ident) {  // VAL_ of an environment variable
            skip_to_semicolon();
            return;
        }
        const Token at = peek();
        Message* m = message_by_id(at, unsigned_int("message id"));
        const Token sat = peek();
        const std::string sname = ident("signal name");
        Signal* s = signal_of(m, sat, sname);
        std::map<std::int64_t, std::string> table;
        while (peek().kind == Tok::Number) {
            const Token vt = peek();
            const std::int64_t v = value_key("value");
            const std::string d = string_lit("value description");
            if (table.count(v)) error(vt, "signal '" + sname + "': value " + vt.text + " described twice");
            table[v] = d;
        }
        expect_semicolon();
        if (s) s->value_table = std::move(table);
    }

    void signal_value_type() {
        next();
        const Token at = peek();
        Message* m = message_by_id(at, unsigned_int("message id"));
        const Token sat = peek();
        Signal* s = signal_of(m, sat, ident("signal name"));
        accept_punct(":");
        const Token vt = peek();
        const std::uint64_t t = unsigned_int("value type");
        expect_semicolon();
        if (t > 2) {
            error(vt, "SIG_VALTYPE_ " + vt.text + " is not 0 (integer), 1 (float32) or 2 (float64)");
            return;
        }
        if (s == nullptr) return;
        s->value_type = t == 1 ? ValueType::Float32 : t == 2 ? ValueType::Float64 : ValueType::Integer;
        const std::uint32_t need = t == 1 ? 32 : t == 2 ? 64 : s->length;
        if (s->length != need)
            error(vt, "signal '" + s->name + "' is " + std::to_string(s->length) + " bits but SIG_VALTYPE_ " + vt.text + " needs " + std::to_string(need));
    }

    void extended_multiplexing() {
        next();
        const Token at = peek();
        Message* m = message_by_id(at, unsigned_int("message id"));
        const Token sat = peek();
        Signal* s = signal_of(m, sat, ident("multiplexed signal name"));
        const Token swt = peek();
        const std::string sw = ident("multiplexor switch name");
        std::vector<MuxRange> ranges;
        do {
            const std::uint64_t lo = unsigned_int("range start");
            const Token ht = peek();
            if (ht.kind != Tok::Number || ht.text[0] != '-') fail(ht, "'-' and the range end");
            std::uint64_t hi = 0;
            if (!parse_decimal_u64(std::string_view(ht.text).substr(1), hi))
                throw SyntaxError{ht.line, ht.col, "invalid multiplexor range end '" + ht.text.substr(1) + "' (expected an unsigned integer)"};
            next();
            if (hi < lo) error(ht, "multiplexor range " + std::to_string(lo) + "-" + std::to_string(hi) + " is empty");
            ranges.push_back(MuxRange{lo, hi});
        } while (accept_punct(","));
        expect_semicolon();
        if (s == nullptr) return;
        if (m->find_signal(sw) == nullptr) {
            error(swt, "message '" + m->name + "' has no multiplexor switch '" + sw + "' (multiplexing that cannot be evaluated)");
            return;
        }
        s->multiplexor = sw;
        mux_pos_[m->name + "." + s->name] = swt;
        if (!extended_mux_seen_.count(s)) s->mux_ranges.clear();
        extended_mux_seen_.insert(s);
        s->mux_ranges.insert(s->mux_ranges.end(), ranges.begin(), ranges.end());
        if (s->mux_role == MuxRole::None) s->mux_role = MuxRole::Multiplexed;
    }

    // ---------------------------------------------------------------- final checks
    void finish() {
        const auto cycle_def = db_.attribute_definitions.find("GenMsgCycleTime");
        const auto format_def = db_.attribute_definitions.find("VFrameFormat");
        for (auto& m : db_.messages) {
            // Simple multiplexing: mN signals without SG_MUL_VAL_ use the message's M switch.
            const Signal* switch_sig = nullptr;
            int switches = 0;
            for (const auto& s : m.signals)
                if (s.mux_role == MuxRole::Multiplexor) {
                    switch_sig = &s;
                    ++switches;
                }
            std::set<std::string> orphans;  // lenient: multiplexed signals without a multiplexor, never decoded
            for (auto& s : m.signals) {
                if ((s.mux_role == MuxRole::Multiplexed || s.mux_role == MuxRole::MultiplexedMultiplexor) && s.multiplexor.empty()) {
                    const Token& at = signal_pos_[m.name + "." + s.name];
                    if (switch_sig == nullptr) {
                        soft(at, "signal '" + s.name + "' is multiplexed but message '" + m.name + "' has no multiplexor (M) signal", "signal skipped");
                        orphans.insert(s.name);
                    }
                    else if (switches > 1) error(at, "signal '" + s.name + "': message '" + m.name + "' has several multiplexors; SG_MUL_VAL_ must name the switch");
                    else s.multiplexor = switch_sig->name;
                }
            }
            check_multiplexing(m);
            // A switch named by SG_MUL_VAL_ that is not a multiplexor (M or mNM): cantools never
            // decodes the signals it would select (nor those they select in turn).
            for (bool more = true; more;) {
                more = false;
                for (const auto& s : m.signals) {
                    if (s.multiplexor.empty() || orphans.count(s.name)) continue;
                    const Signal* sw = m.find_signal(s.multiplexor);
                    if (sw == nullptr || sw == &s) continue;  // refused by check_multiplexing
                    if (orphans.count(sw->name)) {
                        orphans.insert(s.name);
                        more = true;
                    } else if (sw->mux_role != MuxRole::Multiplexor && sw->mux_role != MuxRole::MultiplexedMultiplexor) {
                        soft(mux_position(m, s), "signal '" + s.name + "': its multiplexor '" + sw->name + "' is not marked as a multiplexor (M)",
                             "signal skipped");
                        orphans.insert(s.name);
                        more = true;
                    }
                }
            }
            if (!orphans.empty())
                m.signals.erase(std::remove_if(m.signals.begin(), m.signals.end(), [&](const Signal& s) { return orphans.count(s.name) > 0; }),
                                m.signals.end());
            apply_long_names(m);
            if (auto it = m.attributes.find("GenMsgCycleTime"); it != m.attributes.end()) m.cycle_time_ms_ = it->second.number;
            else if (cycle_def != db_.attribute_definitions.end() && cycle_def->second.default_value)
                m.cycle_time_ms_ = cycle_def->second.default_value->number;
            std::string format;
            if (auto it = m.attributes.find("VFrameFormat"); it != m.attributes.end()) format = it->second.text;
            else if (format_def != db_.attribute_definitions.end() && format_def->second.default_value)
                format = format_def->second.default_value->text;
            if (format.find("CANFD") != std::string::npos) m.is_fd = true;
        }
    }

    /// The position to name for a signal's multiplexing: its SG_MUL_VAL_, else its SG_ line.
    const Token& mux_position(const Message& m, const Signal& s) {
        const std::string key = m.name + "." + s.name;
        if (auto it = mux_pos_.find(key); it != mux_pos_.end()) return it->second;
        return signal_pos_[key];
    }

    /// Multiplexing that cannot be evaluated is refused in both modes (issue 25 part 3): a signal
    /// multiplexed by itself, a multiplexor that is not in the message, or a cycle of multiplexors
    /// (Message::is_active follows the chain and would never end).
    void check_multiplexing(const Message& m) {
        const std::size_t n = m.signals.size();
        std::map<std::string_view, std::size_t> index;
        for (std::size_t i = 0; i < n; ++i) index.emplace(m.signals[i].name, i);
        constexpr std::size_t kNone = static_cast<std::size_t>(-1);
        std::vector<std::size_t> parent(n, kNone);
        for (std::size_t i = 0; i < n; ++i) {
            const Signal& s = m.signals[i];
            if (s.multiplexor.empty()) continue;
            if (s.multiplexor == s.name) {
                error(mux_position(m, s), "signal '" + s.name + "' of message '" + m.name + "' is multiplexed by itself (multiplexing that cannot be evaluated)");
            } else if (auto it = index.find(s.multiplexor); it == index.end()) {
                error(mux_position(m, s), "signal '" + s.name + "': its multiplexor '" + s.multiplexor + "' is not in message '" + m.name + "'");
            } else {
                parent[i] = it->second;
            }
        }
        // Each signal's chain of multiplexors, followed once (0 = not seen, 1 = on the current path, 2 = done).
        std::vector<int> state(n, 0);
        for (std::size_t i = 0; i < n; ++i) {
            std::vector<std::size_t> path;
            std::size_t j = i;
            while (j != kNone && state[j] == 0) {
                state[j] = 1;
                path.push_back(j);
                j = parent[j];
            }
            if (j != kNone && state[j] == 1) {  // a cycle: the part of the path from j
                std::string names;
                const auto from = std::find(path.begin(), path.end(), j);
                for (auto k = from; k != path.end(); ++k) names += m.signals[*k].name + " -> ";
                names += m.signals[j].name;
                error(mux_position(m, m.signals[j]), "signal '" + m.signals[j].name + "' of message '" + m.name +
                                                         "': its multiplexors form a cycle (" + names + "), multiplexing that cannot be evaluated");
            }
            for (std::size_t k : path) state[k] = 2;
        }
    }

    /// The long name CANdb++ keeps for a name cut to 32 characters: the SystemSignalLongSymbol /
    /// SystemMessageLongSymbol attribute (what cantools reads), else ...LongName; empty when none.
    static std::string long_name(const std::map<std::string, AttributeValue>& attributes, const char* symbol, const char* name) {
        for (const char* key : {symbol, name})
            if (auto it = attributes.find(key); it != attributes.end() && it->second.is_string && !it->second.text.empty()) return it->second.text;
        return {};
    }

    /// Long names replace the DBC names (at most 32 characters), as cantools does; multiplexor
    /// references follow the new names. A long name already used in its message (or among the
    /// messages) is a warning, and the short name stays.
    void apply_long_names(Message& m) {
        std::map<std::string, std::string> renamed;
        for (auto& s : m.signals) {
            const std::string longer = long_name(s.attributes, "SystemSignalLongSymbol", "SystemSignalLongName");
            if (longer.empty() || longer == s.name) continue;
            if (m.find_signal(longer) != nullptr) {
                soft(signal_pos_[m.name + "." + s.name], "signal '" + s.name + "': long name '" + longer + "' is already a signal of message '" + m.name + "'",
                     "short name kept");
                continue;
            }
            renamed[s.name] = longer;
            s.name = longer;
        }
        for (auto& s : m.signals)
            if (auto it = renamed.find(s.multiplexor); it != renamed.end()) s.multiplexor = it->second;
        const std::string longer = long_name(m.attributes, "SystemMessageLongSymbol", "SystemMessageLongName");
        if (longer.empty() || longer == m.name) return;
        if (db_.find_message(longer) != nullptr)
            soft(message_pos_[m.name], "message '" + m.name + "': long name '" + longer + "' is already a message name", "short name kept");
        else m.name = longer;
    }

    std::string_view text_;
    std::string file_;
    std::vector<Token> toks_;
    std::size_t pos_ = 0;
    struct Problem {
        int line;
        int col;
        std::string text;
    };
    std::vector<Problem> errors_;
    std::size_t dropped_errors_ = 0;
    DbcMode mode_;
    std::vector<Problem> warnings_;
    std::size_t dropped_warnings_ = 0;
    std::set<std::uint64_t> placeholder_ids_;  ///< raw BO_ ids of VECTOR__INDEPENDENT_SIG_MSG
    std::size_t signal_count_ = 0;
    Database db_;
    Message* current_ = nullptr;
    bool current_ok_ = true;
    bool ignore_signals_ = false;
    std::map<std::string, Token> signal_pos_;
    std::map<std::string, Token> mux_pos_;      ///< "message.signal" -> its SG_MUL_VAL_ switch name
    std::map<std::string, Token> message_pos_;  ///< message name -> its BO_ id
    std::set<const Signal*> extended_mux_seen_;
};

}  // namespace

Database parse_dbc(std::string_view text, const std::string& file_name, DbcMode mode) {
    if (text.size() > kDbcMaxBytes) {
        throw CanError(file_name + ": " + std::to_string(text.size()) + " bytes exceed the limit kDbcMaxBytes = " +
                       std::to_string(kDbcMaxBytes) + " for a DBC file");
    }
    Database db = Parser(text, file_name, mode).run();
    return db;
}

}  // namespace emadiag::can
