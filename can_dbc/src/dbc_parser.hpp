// The DBC parser behind parse_dbc (dbc.hpp), one class in five sources: dbc_parser.cpp runs it and
// holds the strict/lenient policy (error, soft), dbc_tokens.cpp the tokenizer and token readers,
// dbc_messages.cpp BO_/SG_/CM_, dbc_attributes.cpp BA_DEF_/BA_DEF_DEF_/BA_/VAL_/SIG_VALTYPE_,
// dbc_multiplexing.cpp SG_MUL_VAL_ and the final checks. Internal to can_dbc/src.
#pragma once

#include "emadiag/can/dbc.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace emadiag::can::detail {

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

const std::set<std::string>& keywords();
/// Keywords accepted and skipped (they carry nothing this library uses).
const std::set<std::string>& skipped_keywords();

/// Decimal digits only, no sign, no overflow.
bool parse_decimal_u64(std::string_view digits, std::uint64_t& out);

/// A limit of docs/limits.md was exceeded: parsing stops (the problems so far are reported).
struct LimitExceeded {
    int line;
    int col;
    std::string message;
};

class Parser {
public:
    Parser(std::string_view text, std::string file, DbcMode mode) : text_(text), file_(std::move(file)), mode_(mode) {}

    Database run();

private:
    // ---------------------------------------------------------------- tokenizer (dbc_tokens.cpp)
    void tokenize();

    // ---------------------------------------------------------------- helpers (dbc_tokens.cpp)
    const Token& peek(std::size_t ahead = 0) const { return toks_[std::min(pos_ + ahead, toks_.size() - 1)]; }
    const Token& next() {
        const Token& t = toks_[pos_];
        if (pos_ + 1 < toks_.size()) ++pos_;
        return t;
    }
    static std::string describe(const Token& t);
    [[noreturn]] static void fail(const Token& t, const std::string& what);
    // problems: an error, or a soft problem that only strict mode refuses (dbc_parser.cpp)
    void error(int line, int col, const std::string& message);
    void error(const Token& t, const std::string& message) { error(t.line, t.col, message); }
    void soft(int line, int col, const std::string& message, const std::string& outcome);
    void soft(const Token& t, const std::string& message, const std::string& outcome) { soft(t.line, t.col, message, outcome); }

    void expect_punct(const char* p);
    bool accept_punct(const char* p);
    std::string ident(const char* what);
    std::string string_lit(const char* what);
    double number(const char* what);
    double limit_number(const char* what);
    std::int64_t value_key(const char* what);
    std::uint64_t unsigned_int(const char* what);
    void expect_semicolon();
    void recover(std::size_t start);
    void skip_to_semicolon();
    void skip_block();

    // ---------------------------------------------------------------- statements
    // dispatch on the keyword (dbc_parser.cpp)
    void statement();
    // BO_, SG_, CM_ (dbc_messages.cpp)
    void message();
    void signal();
    Message* message_by_id(const Token& at, std::uint64_t raw_id);
    Signal* signal_of(Message* m, const Token& at, const std::string& name);
    void comment();
    // BA_DEF_, BA_DEF_DEF_, BA_, VAL_, SIG_VALTYPE_ (dbc_attributes.cpp)
    void attribute_definition();
    /// Reads an attribute value token (number or string) and checks it against the definition.
    struct Literal {
        AttributeValue value;
        bool skip = false;  ///< lenient: not stored (a warning said so)
    };
    Literal attribute_literal(const AttributeDefinition* def, const Token& at);
    void attribute_default();
    void attribute_value();
    void value_descriptions();
    void signal_value_type();

    // ---------------------------------------------------------------- SG_MUL_VAL_ and final checks (dbc_multiplexing.cpp)
    void extended_multiplexing();
    void finish();
    const Token& mux_position(const Message& m, const Signal& s);
    void check_multiplexing(const Message& m);
    static std::string long_name(const std::map<std::string, AttributeValue>& attributes, const char* symbol, const char* name);
    void apply_long_names(Message& m);

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

}  // namespace emadiag::can::detail
