// emadiag fleet [--db FILE] [--format text|json|csv] [--out FILE] [--draws 1000] [--seed 1]:
// the reliability engineer's fleet view (prognostics/fleet_view.hpp): every tail and position with
// the serial installed now, ranked by urgency (the lower bound of the 90 % RUL interval, then the
// last verdict) with the parameter that drives it. Read from the summary tables, so it takes about
// the same time for a year of one aircraft as for a fleet's.
#include "cli/command.hpp"
#include "cli/numeric_option.hpp"
#include "cli/db_source.hpp"
#include "cli/output_file.hpp"

#include "prognostics/fleet_view.hpp"

#include <iomanip>
#include <memory>
#include <sstream>

namespace emadiag::cli {
namespace {

/// A crossing horizon of less than one flight cycle predicts nothing.
constexpr double kMinHorizonCycles = 1.0;

namespace pg = emadiag::prognostics;

struct FleetCliOptions {
    std::string db = "maintenance.db";
    std::string format = "text";
    std::string out;
    pg::FleetOptions fleet;
};

std::string num(double v, int digits = 4) {
    std::ostringstream os;
    os << std::setprecision(digits) << v;
    return os.str();
}

std::string whole(const std::optional<double>& v) {
    if (!v) return "-";
    std::ostringstream os;
    os << std::fixed << std::setprecision(0) << *v;
    return os.str();
}

const pg::FleetParameter* driver(const pg::FleetRow& r) {
    for (const auto& p : r.parameters)
        if (p.parameter == r.driving_parameter) return &p;
    return nullptr;
}

std::string driver_text(const pg::FleetRow& r) {
    const auto* p = driver(r);
    if (!p) return "-";
    const std::string unit = p->axis == "cycles" ? " cycles" : " days";
    std::string s = p->parameter + " " + num(p->latest) + ", ";
    if (p->rul.status == pg::RulStatus::AlreadyExceeded) return s + "limit exceeded";
    const auto bound = [&](const std::optional<double>& b) { return b ? whole(b) : "> " + whole(p->rul.horizon_days); };
    if (p->rul.rul_days) s += "RUL " + whole(p->rul.rul_days) + unit + " ";
    return s + "[" + bound(p->rul.rul_lower_days) + ", " + bound(p->rul.rul_upper_days) + "]" + unit;
}

std::string text_fleet(const std::vector<pg::FleetRow>& rows, const pg::FleetOptions& o) {
    std::ostringstream os;
    os << "emadiag fleet: " << rows.size() << " positions, most urgent first (90 % RUL lower bound in days, cycles converted at each "
          "position's own rate; then the last verdict); "
       << o.rul.draws << " Monte Carlo draws, seed " << o.rul.seed << "\n";
    os << std::left << std::setw(6) << "rank" << std::setw(10) << "tail" << std::setw(10) << "position" << std::setw(8) << "ATA" << std::setw(20)
       << "serial" << std::setw(10) << "sessions" << std::setw(14) << "last verdict" << std::setw(11) << "lower (d)" << std::setw(31)
       << "status" << "driven by\n";
    for (const auto& r : rows) {
        os << std::left << std::setw(6) << r.rank << std::setw(10) << escape_text(r.tail_number) << std::setw(10) << escape_text(r.position)
           << std::setw(8) << escape_text(r.ata_reference) << std::setw(20) << escape_text(r.actuator_serial) << std::setw(10) << r.sessions
           << std::setw(14) << escape_text(r.last_verdict) << std::setw(11) << whole(r.urgency_days) << std::setw(31) << escape_text(r.status)
           << escape_text(driver_text(r)) << '\n';
    }
    return os.str();
}

std::string csv_fleet(const std::vector<pg::FleetRow>& rows) {
    std::ostringstream os;
    os << "rank,tail_number,position,ata_reference,actuator_serial,sessions,last_utc,last_verdict,last_cycles,status,urgency_days,"
          "driving_parameter,axis,latest,rul,rul_ci90_lower,rul_ci90_upper\n";
    const auto opt = [](const std::optional<double>& v) {
        std::ostringstream s;
        s << std::setprecision(10);
        if (v) s << *v;
        return s.str();
    };
    for (const auto& r : rows) {
        const auto* p = driver(r);
        os << r.rank << ',' << csv_field(r.tail_number) << ',' << csv_field(r.position) << ',' << csv_field(r.ata_reference) << ','
           << csv_field(r.actuator_serial) << ',' << r.sessions << ',' << csv_field(r.last_utc) << ',' << csv_field(r.last_verdict) << ','
           << (r.last_cycles ? std::to_string(*r.last_cycles) : "") << ',' << csv_field(r.status) << ',' << opt(r.urgency_days) << ','
           << csv_field(r.driving_parameter) << ',' << (p ? csv_field(p->axis) : "") << ',' << (p ? opt(p->latest) : "") << ',' << (p ? opt(p->rul.rul_days) : "")
           << ',' << (p ? opt(p->rul.rul_lower_days) : "") << ',' << (p ? opt(p->rul.rul_upper_days) : "") << '\n';
    }
    return os.str();
}

const bool registered = register_command(Command{
    "fleet", "Fleet view: every tail and position ranked by urgency (RUL lower bound, then status) with the parameter that drives it",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<FleetCliOptions>();
        sub.add_option("--db", o->db, "Maintenance database: SQLite file, or a fleet server postgresql://... (docs/fleet-server.md)")
            ->capture_default_str()
            ->check(sqlite_file_or_fleet_uri());
        sub.add_option("--format", o->format, "text, json or csv")->capture_default_str()->check(CLI::IsMember({"text", "json", "csv"}));
        sub.add_option("--out", o->out, "Write to this file (whole, or not at all) instead of stdout");
        sub.add_option("--draws", o->fleet.rul.draws, "Monte Carlo draws per RUL interval")->capture_default_str();
        sub.add_option("--seed", o->fleet.rul.seed, "Seed of the Monte Carlo draws")->capture_default_str();
        sub.add_option("--horizon-days", o->fleet.rul.horizon_days, "Crossing horizon, days")->capture_default_str();
        sub.add_option("--horizon-cycles", o->fleet.horizon_cycles, "Crossing horizon, flight cycles")->capture_default_str()
            ->check(in_range(kMinHorizonCycles, prognostics::kMaxHorizonDays, "kMinHorizonCycles, kMaxHorizonDays"));
        return [o] {
            db::OpenedSource database = db::open_record_source(o->db);
            const auto rows = pg::build_fleet_view(*database.source, o->fleet);
            write_output(o->out,
                         o->format == "json"  ? pg::to_json(rows, o->fleet).dump(2) + "\n"
                         : o->format == "csv" ? csv_fleet(rows)
                                              : text_fleet(rows, o->fleet),
                         database_input(o->db));
            return 0;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
