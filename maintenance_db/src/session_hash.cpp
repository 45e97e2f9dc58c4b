// The hash chain of a tail's sessions (docs/record-format.md, "Hash chain"): each session's stored
// content, in canonical order, hashed with its predecessor's hash.
#include "session_store_detail.hpp"

#include "emadiag/db/sha256.hpp"

#include <algorithm>
#include <charconv>
#include <string_view>
#include <tuple>

namespace emadiag::db {
using namespace detail;

namespace {
/// The tag that starts every session's hashed content (docs/record-format.md).
constexpr std::string_view kSessionHashTag = "emadiag-session-v1";

/// Appends one field as "name:length:bytes\n"; a missing value as "name:-\n".
class Canon {
public:
    explicit Canon(Sha256& h) : h_(h) {}
    void text(std::string_view name, std::string_view v) {
        // "name:length:" built on the stack (this runs some 60 times per stored session).
        char head[96];
        std::size_t n = std::min(name.size(), sizeof head - 24);
        std::copy_n(name.data(), n, head);
        head[n++] = ':';
        const auto r = std::to_chars(head + n, head + sizeof head - 1, v.size());
        n = static_cast<std::size_t>(r.ptr - head);
        head[n++] = ':';
        h_.update(std::string_view(head, n)).update(v).update("\n");
    }
    void number(std::string_view name, double v) {
        if (v == 0) v = 0.0;  // SQLite stores -0.0 as the integer 0: hash both as "0"
        char buf[64];
        const auto r = std::to_chars(buf, buf + sizeof buf, v);  // shortest form that reads back exactly
        text(name, std::string_view(buf, static_cast<std::size_t>(r.ptr - buf)));
    }
    void integer(std::string_view name, std::int64_t v) { text(name, std::to_string(v)); }
    void none(std::string_view name) { h_.update(name).update(":-\n"); }
    void opt(std::string_view name, const std::optional<double>& v) { v ? number(name, *v) : none(name); }
    void opt(std::string_view name, const std::optional<std::int64_t>& v) { v ? integer(name, *v) : none(name); }
    void opt(std::string_view name, const std::optional<std::string>& v) { v ? text(name, *v) : none(name); }

private:
    Sha256& h_;
};
}  // namespace

/// The content hash of `s` with its limits hash given (the store computes it without copying `s`).
std::string detail::content_sha256(const StoredTestSession& s, const std::string& limits_sha256, const std::string& prev_sha256) {
    Sha256 h;
    h.update(kSessionHashTag).update("\n");
    Canon c(h);
    c.text("prev_sha256", prev_sha256);
    c.text("tail_number", s.tail_number);
    c.opt("position", s.position);
    c.text("actuator_serial", s.actuator_serial);
    c.text("phase", s.phase);
    c.text("started_utc", s.started_utc);
    c.opt("cycles", s.cycles);
    c.opt("hours_h", s.hours_h);
    c.text("operator_id", s.operator_id);
    c.text("technician_name", s.technician_name);
    c.text("technician_certificate", s.technician_certificate);
    c.text("work_performed", s.work_performed);
    c.text("source", s.source);
    c.text("tool_version", s.tool_version);
    c.text("verdict", s.verdict);
    c.text("verdict_note", s.verdict_note);
    c.text("limits_json", s.limits_json);
    c.text("limits_sha256", limits_sha256);
    c.opt("amends_session_id", s.amends_session_id);
    c.text("correction_reason", s.correction_reason);
    std::vector<const StoredArtifact*> artifacts;
    for (const auto& a : s.artifacts) artifacts.push_back(&a);
    std::sort(artifacts.begin(), artifacts.end(), [](const auto* a, const auto* b) { return std::tie(a->role, a->name) < std::tie(b->role, b->name); });
    c.integer("artifacts", static_cast<std::int64_t>(artifacts.size()));
    for (const auto* ap : artifacts) {
        const StoredArtifact& a = *ap;
        c.text("role", a.role);
        c.text("name", a.name);
        c.text("sha256", a.sha256);
    }
    c.integer("runs", static_cast<std::int64_t>(s.runs.size()));
    for (const auto& r : s.runs) {
        c.text("run.actuator_serial", r.actuator_serial);
        c.text("run.started_utc", r.started_utc);
        c.text("run.source", r.source);
        c.text("run.load_case", r.load_case);
        c.text("run.sequence", r.sequence);
        c.number("run.k_t_nm_per_a", r.k_t_nm_per_a);
        c.number("run.j_kgm2", r.j_kgm2);
        c.number("run.tau", r.tau);
        c.number("run.sample_period_s", r.sample_period_s);
        c.integer("run.valid", r.valid ? 1 : 0);
        c.text("run.status_note", r.status_note);
        c.text("run.meta_json", r.meta_json);
        c.integer("run.samples", static_cast<std::int64_t>(r.samples.size()));
        for (const auto& x : r.samples) {
            for (double v : {x.t_s, x.current_a, x.speed_rad_s, x.theta_m_rad, x.hinge_moment_nm, x.command_deg}) c.number("x", v);
        }
        c.text("run.raw_log_format", r.raw_log_format);
        c.text("run.raw_log_sha256", sha256_hex(r.raw_log));
        auto est = r.estimates;
        std::sort(est.begin(), est.end(), [](const auto& a, const auto& b) { return std::tie(a.estimator, a.parameter) < std::tie(b.estimator, b.parameter); });
        c.integer("run.estimates", static_cast<std::int64_t>(est.size()));
        for (const auto& e : est) {
            c.text("estimator", e.estimator);
            c.text("parameter", e.parameter);
            c.opt("value", e.value);
            c.number("std_error", e.std_error);
            c.integer("identifiable", e.identifiable ? 1 : 0);
            c.text("method", e.method);
            c.text("note", e.note);
        }
    }
    std::vector<const StoredFinding*> findings;
    for (const auto& f : s.findings) findings.push_back(&f);
    std::sort(findings.begin(), findings.end(),
              [](const auto* a, const auto* b) { return std::tie(a->parameter, a->estimator) < std::tie(b->parameter, b->estimator); });
    c.integer("findings", static_cast<std::int64_t>(findings.size()));
    for (const auto* fp : findings) {
        const StoredFinding& f = *fp;
        c.text("parameter", f.parameter);
        c.text("estimator", f.estimator);
        c.opt("value", f.value);
        c.opt("std_error", f.std_error);
        c.opt("limit_value", f.limit_value);
        c.text("limit_kind", f.limit_kind);
        c.text("status", f.status);
        c.text("note", f.note);
    }
    return h.hex();
}

std::string session_content_sha256(const StoredTestSession& s, const std::string& prev_sha256) {
    return content_sha256(s, s.limits_sha256, prev_sha256);
}

}  // namespace emadiag::db
