// emadiag report --tail T [--db FILE] [--format text|json|csv|html] [--out FILE] [--phase all|pre-flight|...]
//   [--horizon-days 3650] [--horizon-cycles 20000] [--draws 4000] [--seed 1]:
// the maintenance record of one aircraft (prognostics/fleet_record.hpp, docs/fleet-record.md): per
// position and per actuator serial the session history, each parameter's trend against flight
// cycles and days with the fitted degradation, the limit crossing and the RUL with its 90 %
// interval, the installations and the open discovery findings. (`trend` is the calendar view of the
// same record, per position.) HTML is one self-contained file written by the rendering module
// (report/record_adapter.hpp, report/html_report.hpp, docs/report-html.md).
#include "cli/command.hpp"
#include "cli/numeric_option.hpp"
#include "cli/db_source.hpp"
#include "cli/output_file.hpp"

#include "core/emadiag_error.hpp"
#include "estimation/health_estimate.hpp"
#include "prognostics/fleet_record.hpp"
#include "prognostics/utc_time.hpp"
#include "report/html_report.hpp"
#include "report/record_adapter.hpp"

#include <iostream>

#include <iomanip>
#include <memory>
#include <sstream>

namespace emadiag::cli {
namespace {

/// A crossing horizon of less than one flight cycle predicts nothing.
constexpr double kMinHorizonCycles = 1.0;

namespace pg = emadiag::prognostics;

struct ReportCliOptions {
    std::string db = "maintenance.db";
    std::string tail;
    std::string format = "text";
    std::string out;
    pg::FleetRecordOptions record;
};

std::string num(double v, int digits = 4) {
    std::ostringstream os;
    os << std::setprecision(digits) << v;
    return os.str();
}

std::string whole(double v) {
    std::ostringstream os;
    os << std::fixed << std::setprecision(0) << v;
    return os.str();
}

std::string rul_text(const pg::AxisTrend& a) {
    const pg::RulEstimate& r = a.trend.rul;
    const std::string unit = a.axis == pg::kAxisCycles ? " cycles" : " days";
    const auto bound = [&](const std::optional<double>& b) { return b ? whole(*b) : "> " + whole(r.horizon_days); };
    switch (r.status) {
        case pg::RulStatus::Predicted: return whole(*r.rul_days) + unit + " [" + bound(r.rul_lower_days) + ", " + bound(r.rul_upper_days) + "]";
        case pg::RulStatus::AlreadyExceeded: return "0 (limit exceeded at session " + std::to_string(*r.exceeded_session_id) + ")";
        case pg::RulStatus::NoCrossing:
            return "> " + whole(r.horizon_days) + unit + (r.rul_lower_days ? " (90 % lower bound " + whole(*r.rul_lower_days) + ")" : "");
        case pg::RulStatus::NoLimit: return "- (no limit)";
        case pg::RulStatus::InsufficientData: return "- (insufficient data)";
    }
    return "-";
}

void print_view(std::ostream& os, const pg::HistoryView& v) {
    if (v.kind == "position") {
        os << "\nPOSITION " << escape_text(v.key);
        if (!v.ata_reference.empty()) os << " (ATA " << escape_text(v.ata_reference) << (v.description.empty() ? "" : ", " + escape_text(v.description)) << ")";
        os << ": serial installed " << (v.current_serial.empty() ? "?" : escape_text(v.current_serial));
    } else {
        os << "\nSERIAL " << escape_text(v.key) << ": last seen at " << escape_text(v.current_place);
    }
    os << ", " << v.sessions.size() << " sessions, last verdict " << escape_text(v.last_verdict) << '\n';
    for (const auto& i : v.installations)
        os << "  installed " << escape_text(i.detected_utc) << "  " << escape_text(i.tail_number) << ' ' << escape_text(i.position) << ": "
           << (i.from_serial.empty() ? "(none recorded)" : escape_text(i.from_serial)) << " -> " << escape_text(i.to_serial)
           << (i.cycles ? " at " + std::to_string(*i.cycles) + " cycles" : "") << '\n';
    os << "  " << std::left << std::setw(8) << "param" << std::setw(8) << "axis" << std::setw(8) << "points" << std::setw(30) << "latest [95 %]"
       << std::setw(22) << "trend per 100 (se)" << std::setw(12) << "model" << std::setw(12) << "crossing" << "RUL [90 %]\n";
    for (const auto& p : v.parameters) {
        for (const auto& a : p.axes) {
            const auto& t = a.trend;
            std::string latest = "-";
            if (!t.series.points.empty()) {
                const auto& l = t.series.points.back();
                latest = num(l.value) + " [" + num(l.value - kZ95 * l.std_error) + ", " + num(l.value + kZ95 * l.std_error) + "]";
            }
            std::string crossing = "-";
            if (t.rul.status == pg::RulStatus::Predicted && t.rul.crossing_t_days)
                crossing = a.axis == pg::kAxisDays && t.crossing_days_since_epoch ? pg::format_utc_date(*t.crossing_days_since_epoch)
                                                                                  : "cycle " + whole(*t.rul.crossing_t_days);
            os << "  " << std::left << std::setw(8) << p.parameter << std::setw(8) << (a.axis + (a.axis == p.preferred_axis ? "*" : ""))
               << std::setw(8) << t.series.points.size() << std::setw(30) << latest << std::setw(22)
               << (t.trend_per_period ? num(*t.trend_per_period, 3) + " (" + num(*t.trend_per_period_se, 2) + ")" : "-") << std::setw(12)
               << (t.has_fit ? pg::to_string(t.fits.choice.model) : "-") << std::setw(12) << crossing << rul_text(a) << '\n';
        }
    }
    os << "  history:\n";
    for (const auto& s : v.sessions) {
        os << "    " << std::right << std::setw(6) << s.session_id << "  " << std::left << std::setw(21) << escape_text(s.started_utc) << std::setw(8)
           << escape_text(s.tail_number) << ' ' << std::setw(8) << escape_text(s.position.value_or("-")) << ' ' << std::setw(20) << escape_text(s.actuator_serial)
           << ' ' << std::setw(12) << escape_text(s.phase) << std::setw(8) << (s.cycles ? std::to_string(*s.cycles) : "-") << std::setw(14) << escape_text(s.verdict)
           << (s.technician_name.empty() ? ""
                                         : escape_text(s.technician_name) +
                                               (s.technician_certificate.empty() ? "" : " (" + escape_text(s.technician_certificate) + ")"))
           << (s.tool_version.empty() ? "" : "  [emadiag " + escape_text(s.tool_version) + "]") << '\n';
    }
    for (const auto& n : v.notes) os << "  note: " << escape_text(n) << '\n';
}

std::string text_report(const pg::FleetRecord& r) {
    std::ostringstream os;
    os << "emadiag report: tail " << escape_text(r.tail_number) << " (" << escape_text(io::redact_uri_passwords(r.database)) << "), " << r.sessions_total << " sessions, phase " << r.options.phase
       << "; chain head " << r.chain_head_sha256.substr(0, 16) << "...\n"
       << "trends per position (the serial installed now) and per serial (all tails); axis * = preferred (cycles when every session has "
          "them); RUL 90 % intervals from "
       << r.options.rul.draws << " Monte Carlo draws, seed " << r.options.rul.seed << '\n';
    if (!r.amended_session_ids.empty()) {
        os << "amended by a correction, left out:";
        for (auto id : r.amended_session_ids) os << ' ' << id;
        os << '\n';
    }
    for (const auto& v : r.positions) print_view(os, v);
    for (const auto& v : r.serials) print_view(os, v);
    os << "\nopen discovery findings: " << (r.open_findings.empty() ? "none" : std::to_string(r.open_findings.size())) << '\n';
    for (const auto& f : r.open_findings)
        os << "  #" << f.finding_id << "  " << escape_text(f.found_utc) << "  " << escape_text(f.position.value_or("-")) << ' '
           << escape_text(f.actuator_serial) << ": " << escape_text(f.summary) << '\n';
    return os.str();
}

std::string csv_report(const pg::FleetRecord& r) {
    std::ostringstream os;
    os << "tail_number,view,key,parameter,axis,preferred,points,latest,latest_std_error,model,trend_per_100,trend_per_100_se,limit_kind,"
          "limit_value,rul_status,rul,rul_ci90_lower,rul_ci90_upper,horizon,crossing_t\n";
    os << std::setprecision(10);
    const auto opt = [](const std::optional<double>& v) {
        std::ostringstream s;
        s << std::setprecision(10);
        if (v) s << *v;
        return s.str();
    };
    for (const auto* views : {&r.positions, &r.serials}) {
        for (const auto& v : *views) {
            for (const auto& p : v.parameters) {
                for (const auto& a : p.axes) {
                    const auto& t = a.trend;
                    const auto* last = t.series.points.empty() ? nullptr : &t.series.points.back();
                    os << csv_field(r.tail_number) << ',' << v.kind << ',' << csv_field(v.key) << ',' << p.parameter << ',' << a.axis << ','
                       << (a.axis == p.preferred_axis ? 1 : 0) << ',' << t.series.points.size() << ','
                       << (last ? opt(last->value) : "") << ',' << (last ? opt(last->std_error) : "") << ','
                       << (t.has_fit ? pg::to_string(t.fits.choice.model) : "") << ',' << opt(t.trend_per_period) << ','
                       << opt(t.trend_per_period_se) << ',' << (t.series.limit ? pg::to_string(t.series.limit->side) : "") << ','
                       << (t.series.limit ? opt(t.series.limit->value) : "") << ',' << pg::to_string(t.rul.status) << ','
                       << opt(t.rul.rul_days) << ',' << (t.rul.interval_computed ? opt(t.rul.rul_lower_days) : "") << ','
                       << (t.rul.interval_computed ? opt(t.rul.rul_upper_days) : "") << ',' << t.rul.horizon_days << ','
                       << opt(t.rul.crossing_t_days) << '\n';
                }
            }
        }
    }
    return os.str();
}

const bool registered = register_command(Command{
    "report", "Maintenance record of one aircraft: per position and per serial the history, trends in cycles and days, RUL, findings",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<ReportCliOptions>();
        sub.add_option("--db", o->db, "Maintenance database: SQLite file, or a fleet server postgresql://... (docs/fleet-server.md)")
            ->capture_default_str()
            ->check(sqlite_file_or_fleet_uri());
        sub.add_option("--tail", o->tail, "Aircraft tail number")->required();
        sub.add_option("--format", o->format, "text, json, csv or html (one self-contained file with the plots, docs/report-html.md)")->capture_default_str()->check(CLI::IsMember({"text", "json", "csv", "html"}));
        sub.add_option("--out", o->out, "Write the report to this file (whole, or not at all) instead of stdout");
        sub.add_option("--phase", o->record.phase, "Sessions of this phase in the trends: all, pre-flight, post-flight, in-flight, load-rig")
            ->capture_default_str();
        sub.add_option("--horizon-days", o->record.rul.horizon_days, "Crossing horizon after the last session, days")->capture_default_str();
        sub.add_option("--horizon-cycles", o->record.horizon_cycles, "Crossing horizon after the last session, flight cycles")->capture_default_str()
            ->check(in_range(kMinHorizonCycles, prognostics::kMaxHorizonDays, "kMinHorizonCycles, kMaxHorizonDays"));
        sub.add_option("--draws", o->record.rul.draws, "Monte Carlo draws for the RUL intervals")->capture_default_str();
        sub.add_option("--seed", o->record.rul.seed, "Seed of the Monte Carlo draws (recorded in the report)")->capture_default_str();
        return [o] {
            db::OpenedSource database = db::open_record_source(o->db);
            const pg::FleetRecord record = pg::build_fleet_record(*database.source, o->tail, o->record);
            // A record changed or damaged outside the tool is said in the report itself (and exit 5).
            const std::vector<std::string> broken = database.source->record_problems(o->tail);
            std::string warning;
            if (!broken.empty()) {
                warning = "RECORD CHANGED OR DAMAGED OUTSIDE THE TOOL: the hash chain of " + o->tail + " is broken (" +
                          std::to_string(broken.size()) + " problem(s); the first: " + broken.front() +
                          "); what follows may not be what was recorded: run emadiag verify --tail " + o->tail;
                std::cerr << "emadiag report: " << warning << '\n';
            }
            std::string text;
            if (o->format == "json") {
                auto j = pg::to_json(record);
                if (!broken.empty()) j["record_integrity"] = {{"intact", false}, {"problems", broken}};
                text = j.dump(2) + "\n";
            } else if (o->format == "html") {
                text = report::render_html(report::from_fleet_record(record, {pg::now_utc_time(), EMADIAG_VERSION, o->db}));
            } else if (o->format == "csv") {
                text = csv_report(record);
            } else {
                text = text_report(record);
            }
            if (!warning.empty() && (o->format == "text" || o->format == "csv")) text = "# " + escape_text(warning) + "\n" + text;
            if (!warning.empty() && o->format == "html") {
                const std::string banner = "<p role=\"alert\" style=\"border:3px solid #b00;padding:8px;color:#b00;font-weight:bold\">" +
                                           report::html_escape(warning) + "</p>\n";
                const auto body = text.find("<body");
                const auto at = body == std::string::npos ? std::string::npos : text.find('>', body);
                text.insert(at == std::string::npos ? 0 : at + 1, "\n" + banner);
            }
            write_output(o->out, text, database_input(o->db));
            if (!o->out.empty())
                std::cerr << "wrote the " << o->format << " report of " << o->tail << " to " << escape_text(o->out) << " (" << text.size() << " bytes)\n";
            return broken.empty() ? 0 : 5;  // as emadiag verify: the record was changed outside the tool
        };
    }});

}  // namespace
}  // namespace emadiag::cli
