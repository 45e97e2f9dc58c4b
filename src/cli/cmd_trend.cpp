// emadiag trend --db FILE --tail N123EM [--position P] [--serial S] [--phase pre-flight|post-flight|all]
//   [--horizon-days 3650] [--draws 4000] [--seed S] [--json | --format text|json|html] [--out FILE]:
// the reliability engineer's trend report of one aircraft from its stored test sessions
// (prognostics/trend_report.hpp), per actuator: each position with the serial installed there now
// (or the one position or serial asked for), and for each health parameter the measurements, the
// degradation model, the predicted limit crossing and the remaining useful life with its 90 %
// interval. The sessions are grouped as `report` groups them (prognostics/fleet_record.hpp): two
// actuators are never fitted as one line. Text for people; --json is the stable schema of
// docs/trend-report.md; html is the maintenance record's HTML of the same positions or serial
// (report/record_adapter.hpp, docs/report-html.md).
#include "cli/command.hpp"
#include "cli/db_source.hpp"
#include "cli/output_file.hpp"

#include "core/emadiag_error.hpp"
#include "emadiag/db/database.hpp"
#include "estimation/health_estimate.hpp"
#include "prognostics/fleet_record.hpp"
#include "prognostics/trend_report.hpp"
#include "prognostics/utc_time.hpp"
#include "report/html_report.hpp"
#include "report/record_adapter.hpp"

#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

namespace emadiag::cli {
namespace {

namespace pg = emadiag::prognostics;

struct TrendCliOptions {
    std::string db;
    std::string tail;
    std::string position, serial;
    std::string phase = "pre-flight";
    double horizon_days = pg::kDefaultHorizonDays;
    int draws = pg::kDefaultMonteCarloDraws;
    std::uint64_t seed = 1;
    bool json = false;
    std::string format = "text";
    std::string out;
};

std::string num(double v, int digits = 4) {
    std::ostringstream os;
    os << std::setprecision(digits) << v;
    return os.str();
}

std::string signed_num(double v, int digits = 3) { return (v >= 0 ? "+" : "") + num(v, digits); }

std::string days(double v) {
    std::ostringstream os;
    os << std::fixed << std::setprecision(0) << v;
    return os.str();
}

std::string latest_text(const pg::ParameterTrend& p) {
    if (p.series.points.empty()) return "-";
    const auto& last = p.series.points.back();
    return num(last.value) + " [" + num(last.value - kZ95 * last.std_error) + ", " + num(last.value + kZ95 * last.std_error) + "]";
}

std::string trend_text(const pg::ParameterTrend& p) {
    if (!p.trend_per_period) return "-";
    return signed_num(*p.trend_per_period) + " +/- " + num(*p.trend_per_period_se, 2);
}

std::string crossing_text(const pg::ParameterTrend& p) {
    if (!p.crossing_days_since_epoch || p.rul.status != pg::RulStatus::Predicted) return "-";
    return pg::format_utc_date(*p.crossing_days_since_epoch);
}

std::string interval_text(const pg::RulEstimate& r) {
    const std::string lo = r.rul_lower_days ? days(*r.rul_lower_days) : "> " + days(r.horizon_days);
    const std::string hi = r.rul_upper_days ? days(*r.rul_upper_days) : "> " + days(r.horizon_days);
    return "[" + lo + ", " + hi + "]";
}

std::string rul_text(const pg::ParameterTrend& p) {
    const pg::RulEstimate& r = p.rul;
    switch (r.status) {
        case pg::RulStatus::Predicted: return days(*r.rul_days) + " " + interval_text(r);
        case pg::RulStatus::AlreadyExceeded: return "0 (limit exceeded at session " + std::to_string(*r.exceeded_session_id) + ")";
        case pg::RulStatus::NoCrossing:
            return "> " + days(r.horizon_days) + (r.rul_lower_days ? " (90 % lower bound " + days(*r.rul_lower_days) + ")" : "");
        case pg::RulStatus::NoLimit: return "- (no limit)";
        case pg::RulStatus::InsufficientData: return "- (insufficient data)";
    }
    return "-";
}

void print_series(std::ostream& os, const pg::TrendSeries& t) {
    if (t.kind == "position")
        os << "\nPOSITION " << t.position << ": serial " << (t.serial.empty() ? "(none recorded)" : t.serial) << " (installed now)";
    else
        os << "\nSERIAL " << (t.serial.empty() ? "(none recorded)" : t.serial) << ": last seen at " << t.place;
    os << ", " << t.sessions_in_trend << " of " << t.sessions_total << " sessions in the trend";
    if (t.origin_days_since_epoch) {
        os << ", day 0 = " << t.origin_utc;
        if (t.last_session_days_since_epoch)
            os << ", last session day " << days(*t.last_session_days_since_epoch - *t.origin_days_since_epoch) << " ("
               << pg::format_utc_date(*t.last_session_days_since_epoch) << ")";
    }
    os << '\n';
    for (const auto& n : t.notes) os << "note: " << n << '\n';
    os << '\n';
    os << std::left << std::setw(8) << "param" << std::setw(10) << "sessions" << std::setw(29) << "latest [95 %]" << std::setw(24)
       << "trend per 100 d (se)" << std::setw(12) << "model" << std::setw(12) << "crossing" << "RUL days [90 %]\n";
    for (const auto& p : t.parameters) {
        os << std::left << std::setw(8) << p.series.parameter << std::setw(10) << p.series.points.size() << std::setw(29) << latest_text(p)
           << std::setw(24) << trend_text(p) << std::setw(12) << (p.has_fit ? pg::to_string(p.fits.choice.model) : "-")
           << std::setw(12) << crossing_text(p) << rul_text(p) << '\n';
    }
    for (const auto& p : t.parameters) {
        os << '\n' << p.series.parameter << " at " << (t.kind == "position" ? t.position : "serial " + t.serial);
        if (p.series.limit) os << " (limit " << pg::to_string(p.series.limit->side) << ' ' << num(p.series.limit->value) << ")";
        os << ": " << p.rul.summary << '\n';
        if (p.has_fit) {
            os << "  model: " << p.fits.choice.reason << '\n';
            for (const auto* f : {&p.fits.linear, &p.fits.log_linear}) {
                if (!f->fitted) {
                    os << "  " << pg::to_string(f->model) << ": not fitted (" << f->note << ")\n";
                    continue;
                }
                os << "  " << std::setw(12) << (std::string(pg::to_string(f->model)) + ":")
                   << (f->model == pg::DegradationModel::Linear ? "y" : "ln y")
                   << " = " << num(f->a, 6) << " " << (f->b >= 0 ? "+ " : "- ") << num(std::abs(f->b), 4) << " t/day"
                   << "   (se b " << num(std::sqrt(f->covariance(1, 1)), 2) << ", reduced chi2 " << num(f->reduced_chi2, 3)
                   << ", AICc " << (f->aicc ? num(*f->aicc, 5) : "-") << ")\n";
            }
        }
        if (p.rul.interval_computed && p.rul.status != pg::RulStatus::AlreadyExceeded) {
            os << "  RUL 90 % interval " << interval_text(p.rul) << " days from " << p.rul.draws << " draws: " << p.rul.draws_beyond_horizon
               << " beyond the horizon, " << p.rul.draws_already_crossed << " already crossed\n";
        }
        if (!p.series.points.empty()) {
            os << "  " << std::right << std::setw(8) << "day" << std::setw(12) << "value" << std::setw(11) << "se" << std::setw(9) << "session"
               << "  started_utc           from\n";
            for (const auto& pt : p.series.points) {
                std::string from;
                for (std::size_t i = 0; i < pt.estimators.size(); ++i) from += (i ? ", " : "") + pt.estimators[i];
                os << "  " << std::right << std::setw(8) << days(pt.t_days) << std::setw(12) << num(pt.value, 5) << std::setw(11)
                   << num(pt.std_error, 2) << std::setw(9) << pt.session_id << "  " << std::left << std::setw(22) << pt.started_utc << from
                   << '\n';
            }
        }
        for (const auto& n : p.series.notes) os << "  note: " << n << '\n';
    }
}

void print_text(std::ostream& os, const pg::TrendReport& r) {
    os << "emadiag trend: tail " << r.tail_number << ", phase " << r.phase << ", " << r.sessions_total << " test sessions";
    if (!r.position_filter.empty()) os << ", position " << r.position_filter;
    if (!r.serial_filter.empty()) os << ", serial " << r.serial_filter;
    os << "; one trend per actuator, " << r.series.size() << " series (";
    for (std::size_t i = 0; i < r.series.size(); ++i)
        os << (i ? ", " : "") << (r.series[i].kind == "position" ? r.series[i].position + " " + r.series[i].serial : r.series[i].serial);
    os << ")\nmeasurements: inverse-variance mean of each session's physics findings; intervals: latest 95 %, RUL 90 % ("
       << r.rul_options.draws << " Monte Carlo draws, seed " << r.rul_options.seed << "); horizon " << days(r.rul_options.horizon_days)
       << " days after the last session; day 0 is each series' first session\n";
    for (const auto& n : r.notes) os << "note: " << n << '\n';
    for (const auto& t : r.series) print_series(os, t);
}

const bool registered = register_command(Command{
    "trend", "Trend report of one aircraft per position (or serial): per parameter the degradation trend, predicted limit crossing and remaining useful life",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<TrendCliOptions>();
        sub.add_option("--db", o->db, "Maintenance database with the test sessions: SQLite file, or a fleet server postgresql://...")
            ->required()
            ->check(sqlite_file_or_fleet_uri());
        sub.add_option("--tail", o->tail, "Aircraft tail number")->required();
        sub.add_option("--position", o->position, "Only this position of the tail (default: every position, each its own trend)");
        sub.add_option("--serial", o->serial, "Only this actuator serial: its own trend across its positions and tails");
        sub.add_option("--phase", o->phase, "Sessions of this phase: pre-flight, post-flight or all")
            ->capture_default_str()
            ->check(CLI::IsMember({"pre-flight", "post-flight", pg::kPhaseAll}));
        sub.add_option("--horizon-days", o->horizon_days, "How far after the last session a crossing is predicted, days")->capture_default_str();
        sub.add_option("--draws", o->draws, "Monte Carlo draws for the RUL interval")->capture_default_str();
        sub.add_option("--seed", o->seed, "Seed of the Monte Carlo draws (recorded in the report)")->capture_default_str();
        sub.add_flag("--json", o->json, "JSON report (docs/trend-report.md); the same as --format json");
        sub.add_option("--format", o->format, "text, json (docs/trend-report.md) or html (one self-contained file, docs/report-html.md)")
            ->capture_default_str()
            ->check(CLI::IsMember({"text", "json", "html"}));
        sub.add_option("--out", o->out, "Write the report to this file (default: standard output)");
        return [o] {
            pg::TrendOptions t;
            t.phase = o->phase;
            t.rul.horizon_days = o->horizon_days;
            t.rul.draws = o->draws;
            t.rul.seed = o->seed;
            t.position = o->position;
            t.serial = o->serial;
            db::OpenedSource database = db::open_record_source(o->db);
            const pg::FleetRecord record = pg::load_trend_record(*database.source, o->tail, t);
            const pg::TrendReport report = pg::trend_report_of(record, t);
            const std::string format = o->json ? "json" : o->format;
            std::ostringstream text;
            if (format == "json") {
                text << pg::to_json(report).dump(2) << '\n';
            } else if (format == "html") {
                // The maintenance record's page of the same positions (or serial): per position, never pooled.
                text << report::render_html(report::from_fleet_record(pg::select_views(record, t.position, t.serial),
                                                                      {pg::now_utc_time(), EMADIAG_VERSION, o->db}));
            } else {
                print_text(text, report);
            }
            if (o->out.empty()) {
                std::cout << text.str();
            } else {
                write_output(o->out, text.str(), database_input(o->db));
                std::cerr << "wrote the " << format << " report of " << o->tail << " to " << escape_text(o->out) << " (" << text.str().size() << " bytes)\n";
            }
            return 0;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
