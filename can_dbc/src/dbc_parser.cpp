// DBC parser: a tokenizer with line:col positions, then one function per keyword.
// Every problem is collected as "file:line:col: message"; after an error the parser resumes at the
// next keyword that starts a line, so one pass reports all problems.
// This file runs the parser and holds the strict/lenient policy (error, soft); dbc_parser.hpp lists
// the files of the other parts.
#include "dbc_parser.hpp"

#include "emadiag/can/can_error.hpp"

#include <algorithm>
#include <charconv>

namespace emadiag::can {
namespace detail {

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

Database Parser::run() {
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

void Parser::error(int line, int col, const std::string& message) {
    if (errors_.size() >= kDbcMaxReportedProblems) {
        ++dropped_errors_;
        return;
    }
    errors_.push_back(Problem{line, col, file_ + ":" + std::to_string(line) + ":" + std::to_string(col) + ": " + message});
}

/// A problem cantools' lenient mode lets pass: an error in strict mode, else a warning that says
/// what was skipped or kept.
void Parser::soft(int line, int col, const std::string& message, const std::string& outcome) {
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

void Parser::statement() {
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

}  // namespace detail

Database parse_dbc(std::string_view text, const std::string& file_name, DbcMode mode) {
    if (text.size() > kDbcMaxBytes) {
        throw CanError(file_name + ": " + std::to_string(text.size()) + " bytes exceed the limit kDbcMaxBytes = " +
                       std::to_string(kDbcMaxBytes) + " for a DBC file");
    }
    Database db = detail::Parser(text, file_name, mode).run();
    return db;
}

}  // namespace emadiag::can
