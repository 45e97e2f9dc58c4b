// DBC parser, the tokens: the tokenizer with line:col positions, and the readers of one token
// (an identifier, a string, a number, a punctuation mark) that the statements are made of.
#include "dbc_parser.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace emadiag::can::detail {

void Parser::tokenize() {
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

std::string Parser::describe(const Token& t) {
    switch (t.kind) {
        case Tok::End: return "end of file";
        case Tok::String: return "string \"" + t.text + "\"";
        default: return "'" + t.text + "'";
    }
}

void Parser::fail(const Token& t, const std::string& what) {
    throw SyntaxError{t.line, t.col, "expected " + what + ", found " + describe(t)};
}

void Parser::expect_punct(const char* p) {
    const Token& t = peek();
    if (t.kind != Tok::Punct || t.text != p) fail(t, std::string("'") + p + "'");
    next();
}

bool Parser::accept_punct(const char* p) {
    if (peek().kind == Tok::Punct && peek().text == p) {
        next();
        return true;
    }
    return false;
}

std::string Parser::ident(const char* what) {
    const Token& t = peek();
    if (t.kind != Tok::Ident) fail(t, what);
    return next().text;
}

std::string Parser::string_lit(const char* what) {
    const Token& t = peek();
    if (t.kind != Tok::String) fail(t, what);
    return next().text;
}

double Parser::number(const char* what) {
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
double Parser::limit_number(const char* what) {
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
std::int64_t Parser::value_key(const char* what) {
    const Token t = peek();
    const double v = number(what);
    // 2^63 is exact in a double; every whole double in [-2^63, 2^63) converts.
    constexpr double kTwo63 = 9223372036854775808.0;
    if (!(v == std::trunc(v) && v >= -kTwo63 && v < kTwo63))
        throw SyntaxError{t.line, t.col, std::string("invalid ") + what + " '" + t.text + "': not a whole number of a signed 64-bit raw value"};
    return static_cast<std::int64_t>(v);
}

std::uint64_t Parser::unsigned_int(const char* what) {
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

void Parser::expect_semicolon() {
    if (peek().kind == Tok::End && mode_ == DbcMode::Lenient) {  // cantools accepts a last statement without it
        soft(peek(), "expected ';' at the end of the file", "statement kept");
        return;
    }
    expect_punct(";");
}

/// Skips to the next keyword that starts a line (after an error in the statement at `start`).
void Parser::recover(std::size_t start) {
    if (pos_ <= start) pos_ = start + 1;
    while (peek().kind != Tok::End) {
        const Token& t = peek();
        if (t.line_start && t.kind == Tok::Ident && keywords().count(t.text)) return;
        next();
    }
}

/// Skips a statement that ends with ';'.
void Parser::skip_to_semicolon() {
    while (peek().kind != Tok::End) {
        if (next().text == ";" ) return;
    }
}

/// Skips tokens until one that starts a line at column 1 (NS_ and BS_ blocks).
void Parser::skip_block() {
    while (peek().kind != Tok::End && !(peek().line_start && peek().col == 1)) next();
}

}  // namespace emadiag::can::detail
