#pragma once
// The parts of record_store.cpp that record_verify.cpp shares: reading rows column by column, a
// tail's chain_heads row and the check of its discovery findings' chain. Not installed.
#include "emadiag/db/database.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace emadiag::db::detail {

/// Reads a result row's columns left to right: each call takes the next column, so a reader lists
/// the fields in the order of its SELECT without numbering them.
class Columns {
public:
    explicit Columns(const Statement& st) : st_(st) {}
    std::string text() { return st_.column_text(col_++); }
    std::int64_t integer() { return st_.column_int(col_++); }
    double real() { return st_.column_double(col_++); }
    std::optional<std::string> optional_text() { return st_.column_is_null(col_) ? skip<std::string>() : std::optional<std::string>(text()); }
    std::optional<std::int64_t> optional_integer() { return st_.column_is_null(col_) ? skip<std::int64_t>() : std::optional<std::int64_t>(integer()); }
    std::optional<double> optional_real() { return st_.column_is_null(col_) ? skip<double>() : std::optional<double>(real()); }

private:
    template <class T>
    std::optional<T> skip() {
        ++col_;
        return std::nullopt;
    }
    const Statement& st_;
    int col_ = 0;
};

/// Every row of a bound statement, each read by `read(Columns&)`: the one query loop of the record.
template <class Read>
auto collect(Statement& st, Read read) {
    std::vector<decltype(read(std::declval<Columns&>()))> out;
    while (st.step()) {
        Columns c(st);
        out.push_back(read(c));
    }
    return out;
}

/// The chain_heads row of a tail: sessions and their head, discovery findings and their head.
struct HeadRow {
    std::int64_t session_id = 0, sessions = 0, discovery_findings = 0;
    std::string content_sha256, discovery_head_sha256;
};
[[nodiscard]] std::optional<HeadRow> head_row(Database& db, const std::string& tail_number);

/// Checks a tail's discovery findings: each one's content hash, and their chain against the head
/// recorded in chain_heads. Adds problems to `out`; returns the recomputed links (oldest first).
std::vector<std::string> check_discovery_chain(Database& db, const std::string& tail_number, const std::optional<HeadRow>& head,
                                               std::vector<std::string>& out);

}  // namespace emadiag::db::detail
