// Checking a test session before it is stored: every field against what the schema accepts, with a
// message that names the field and the value.
#include "session_store_detail.hpp"

#include "emadiag/db/db_error.hpp"

#include "run_store_detail.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <string_view>

namespace emadiag::db {
using namespace detail;

namespace {
// The values the schema's CHECK constraints accept (schema/003_fleet_record.sql); checked here
// first so that the message names the field and the value.
constexpr std::array<std::string_view, 4> kPhases{"pre-flight", "post-flight", "in-flight", "load-rig"};
constexpr std::array<std::string_view, 4> kVerdicts{"SERVICEABLE", "UNSERVICEABLE", "INCONCLUSIVE", "NO_TEST"};
constexpr std::array<std::string_view, 3> kLimitKinds{"max", "min", "none"};
constexpr std::array<std::string_view, 3> kArtifactRoles{"model", "limits", "positions"};
constexpr std::size_t kSha256HexDigits = 64;
/// "YYYY-MM-DDThh:mm:ss": the part of an ISO 8601 time every started_utc begins with ('9' = a digit).
constexpr std::string_view kIsoDateTimePattern = "9999-99-99T99:99:99";

template <std::size_t N>
std::string one_of(const std::array<std::string_view, N>& allowed) {
    std::string out;
    for (std::size_t i = 0; i < N; ++i) {
        if (i > 0) out += i + 1 == N ? " or " : ", ";
        out += "'" + std::string(allowed[i]) + "'";
    }
    return out;
}

template <std::size_t N>
bool is_one_of(std::string_view value, const std::array<std::string_view, N>& allowed) {
    return std::find(allowed.begin(), allowed.end(), value) != allowed.end();
}

/// Throws unless `value` is one of `allowed`; `field()` names it (built only for the message: the
/// bulk store checks millions of values).
template <std::size_t N, typename Field>
void check_one_of(const std::string& value, const std::array<std::string_view, N>& allowed, const Field& field) {
    if (!is_one_of(value, allowed)) throw DbError(field() + " is '" + value + "': use " + one_of(allowed), DbErrorKind::Invalid);
}

bool is_sha256_hex(const std::string& s) {
    return s.size() == kSha256HexDigits &&
           std::all_of(s.begin(), s.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)) || (c >= 'a' && c <= 'f'); });
}
}  // namespace

bool detail::is_iso_date_time(const std::string& text) {
    if (text.size() < kIsoDateTimePattern.size()) return false;
    for (std::size_t i = 0; i < kIsoDateTimePattern.size(); ++i) {
        const bool ok = kIsoDateTimePattern[i] == '9' ? std::isdigit(static_cast<unsigned char>(text[i])) != 0
                                                      : text[i] == kIsoDateTimePattern[i];
        if (!ok) return false;
    }
    return true;
}

void detail::invalid(const std::string& message) { throw DbError(message, DbErrorKind::Invalid); }

namespace {
template <typename Field>
void check_optional_finite(const std::optional<double>& v, const Field& field) {
    if (v && !std::isfinite(*v)) invalid(field() + " is not a finite number (" + std::to_string(*v) + ")");
}
}  // namespace

void detail::check_session(const StoredTestSession& s) {
    // The messages are built only when a check fails (this runs once per stored session).
    const std::string_view where = "test session: ";
    const auto named = [&where](const char* field) { return [&where, field] { return std::string(where) + field; }; };
    if (const auto problem = detail::tail_number_problem(s.tail_number)) invalid(std::string(where) + *problem);
    check_one_of(s.phase, kPhases, named("phase"));
    check_one_of(s.verdict, kVerdicts, named("verdict"));
    if (!is_iso_date_time(s.started_utc)) {
        invalid(std::string(where) + "started_utc '" + s.started_utc + "' is not an ISO 8601 UTC time (" + std::string(kIsoDateTimePattern) +
                "...)");
    }
    if (s.position) {
        if (const auto problem = position_problem(*s.position)) invalid(std::string(where) + *problem);
        if (const auto problem = ata_reference_problem(s.position_ata)) invalid(std::string(where) + "position " + *s.position + ": " + *problem);
    }
    if (s.cycles && *s.cycles < 0) invalid(std::string(where) + "cycles " + std::to_string(*s.cycles) + " is negative");
    check_optional_finite(s.hours_h, named("hours_h"));
    if (s.hours_h && *s.hours_h < 0) invalid(std::string(where) + "hours_h " + std::to_string(*s.hours_h) + " is negative");
    if (s.amends_session_id.has_value() == s.correction_reason.empty())
        invalid(std::string(where) +
                (s.amends_session_id ? "a correction (amends session " + std::to_string(*s.amends_session_id) + ") needs a reason"
                                     : std::string("correction_reason '") + s.correction_reason + "' without amends_session_id"));
    for (std::size_t i = 0; i < s.artifacts.size(); ++i) {
        const auto& a = s.artifacts[i];
        const auto context = [&] { return std::string(where) + "artifact " + std::to_string(i) + " (" + a.name + "): "; };
        check_one_of(a.role, kArtifactRoles, [&] { return context() + "role"; });
        if (a.name.empty()) invalid(context() + "name is empty");
        if (!is_sha256_hex(a.sha256)) invalid(context() + "sha256 '" + a.sha256 + "' is not 64 lowercase hex digits");
        for (std::size_t j = 0; j < i; ++j)
            if (s.artifacts[j].role == a.role && s.artifacts[j].name == a.name) invalid(context() + "duplicate of artifact " + std::to_string(j));
    }
    for (std::size_t i = 0; i < s.runs.size(); ++i) {
        const std::string context = "test session run " + std::to_string(i) + ": ";
        detail::check_run(s.runs[i], context);
        if (s.runs[i].tail_number != s.tail_number) {
            invalid(context + "tail_number '" + s.runs[i].tail_number + "' differs from the session's '" + s.tail_number + "'");
        }
    }
    for (std::size_t i = 0; i < s.findings.size(); ++i) {
        const auto& f = s.findings[i];
        const auto context = [&] { return "test session finding " + std::to_string(i) + " (" + f.parameter + "/" + f.estimator + "): "; };
        if (f.parameter.empty()) invalid(context() + "parameter is empty");
        if (f.estimator.empty()) invalid(context() + "estimator is empty");
        if (f.status.empty()) invalid(context() + "status is empty");
        check_optional_finite(f.value, [&] { return context() + "value"; });
        check_optional_finite(f.std_error, [&] { return context() + "std_error"; });
        if (f.std_error && *f.std_error < 0) invalid(context() + "std_error " + std::to_string(*f.std_error) + " is negative");
        check_one_of(f.limit_kind, kLimitKinds, [&] { return context() + "limit_kind"; });
        check_optional_finite(f.limit_value, [&] { return context() + "limit_value"; });
        if ((f.limit_kind == kNoLimit) == f.limit_value.has_value()) {
            invalid(context() + "limit_kind '" + f.limit_kind + "' " +
                    (f.limit_value ? "with limit_value " + std::to_string(*f.limit_value) : std::string("without a limit_value")) +
                    ": a 'max' or 'min' limit has a value, 'none' has none");
        }
        for (std::size_t j = 0; j < i; ++j) {
            if (s.findings[j].parameter == f.parameter && s.findings[j].estimator == f.estimator) {
                invalid(context() + "duplicate of finding " + std::to_string(j) + ": each (parameter, estimator) is found once per session");
            }
        }
    }
}

std::optional<std::string> position_problem(const std::string& position) {
    bool ok = !position.empty() && position.size() <= kMaxPositionLength;
    for (char c : position)
        ok = ok && (std::isupper(static_cast<unsigned char>(c)) || std::isdigit(static_cast<unsigned char>(c)) || c == '-');
    if (ok) return std::nullopt;
    return "position '" + position + "' is not valid: use 1 to " + std::to_string(kMaxPositionLength) + " characters of A-Z, 0-9 and '-'";
}

std::optional<std::string> ata_reference_problem(const std::string& ata) {
    const bool ok = ata.size() >= 5 && ata.size() <= 16 && ata.compare(0, 3, "27-") == 0 && std::isdigit(static_cast<unsigned char>(ata[3])) &&
                    std::isdigit(static_cast<unsigned char>(ata[4]));
    if (ok) return std::nullopt;
    return "ATA reference '" + ata + "' is not valid: use chapter 27 (flight controls), e.g. 27-30";
}

}  // namespace emadiag::db
