#include "actuator/actuator_profile.hpp"

#include "actuator/actuator_error.hpp"
#include "actuator/operations_reader.hpp"
#include "actuator/profile_reader.hpp"
#include "emadiag/db/sha256.hpp"
#include "emadiag/io/bounded_json.hpp"
#include "emadiag/sim/ema_params.hpp"
#include "measured/units.hpp"

#include <cctype>
#include <cmath>
#include <filesystem>
#include <set>

namespace emadiag::actuator {

using nlohmann::json;
using detail::Bound;
using detail::Null;
using detail::ProfileReader;

const char* to_string(DriveKind k) {
    switch (k) {
        case DriveKind::current_controlled: return "current_controlled";
        case DriveKind::stepper: return "stepper";
        case DriveKind::current_not_torque: return "current_not_torque";
    }
    return "";
}

const char* to_string(OutputKind k) { return k == OutputKind::rotary ? "rotary" : "linear"; }

const char* to_string(LoadMeasuredBy k) { return k == LoadMeasuredBy::sensor ? "sensor" : "set_point"; }

const SensorSignal* Sensors::find(std::string_view name) const {
    for (const SensorSignal& s : signals) {
        if (s.signal == name) return &s;
    }
    return nullptr;
}

const HealthPrior* Operations::prior(std::string_view parameter) const {
    for (const HealthPrior& p : health_priors) {
        if (p.parameter == parameter) return &p;
    }
    return nullptr;
}

namespace {

/// The current model's only form (docs/actuator-profile.md, "The empirical current model").
constexpr const char* kCurrentModelForm = "linear_load_speed/1";
constexpr std::size_t kSha256HexChars = 64;
/// Longest signal name ([a-z][a-z0-9_]*), as in a column map.
constexpr std::size_t kMaxSignalChars = 64;

bool part_number_ok(const std::string& s) {
    bool ok = !s.empty() && s.size() <= kMaxPartNumberChars && std::isalnum(static_cast<unsigned char>(s[0]));
    for (const char c : s) ok = ok && (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '+' || c == '-');
    return ok;
}

bool signal_name_ok(const std::string& s) {
    bool ok = !s.empty() && s.size() <= kMaxSignalChars && s[0] >= 'a' && s[0] <= 'z';
    for (const char c : s) ok = ok && ((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_');
    return ok;
}

void read_identity(ProfileReader& r, const json& root, ActuatorProfile& p) {
    const json* o = r.object(root, "", "identity", Null::refused);
    if (!o) return;
    r.keys(*o, "/identity", {"part_number", "name", "description"});
    if (const auto pn = r.text(*o, "/identity", "part_number", kMaxPartNumberChars, Null::refused)) {
        if (!part_number_ok(*pn)) {
            r.problem("/identity/part_number", "'" + *pn + "' must be a letter or digit, then letters, digits, '.', '_', '+' or '-'");
        }
        p.part_number = *pn;
    }
    p.name = r.text(*o, "/identity", "name", kMaxNameChars, Null::refused).value_or("");
    p.description = r.text(*o, "/identity", "description", kMaxTextChars, Null::allowed).value_or("");
}

/// One direction's coefficients of a calibration; the load and speed keys carry the output's units.
CurrentCoefficients read_coefficients(ProfileReader& r, const json& cal, const std::string& path, const char* key, OutputKind output) {
    CurrentCoefficients c;
    const json* o = r.object(cal, path, key, Null::refused);
    if (!o) return c;
    const std::string at = path + "/" + key;
    const bool linear = output == OutputKind::linear;
    const char* opposing = linear ? "load_opposing_a_per_n" : "load_opposing_a_per_nm";
    const char* aiding = linear ? "load_aiding_a_per_n" : "load_aiding_a_per_nm";
    const char* speed = linear ? "speed_a_s_per_m" : "speed_a_s_per_rad";
    r.keys(*o, at, {"i0_a", opposing, aiding, speed});
    c.i0_a = r.number(*o, at, "i0_a", Bound::finite, Null::refused).value_or(0.0);
    c.load_opposing_a_per_si = r.number(*o, at, opposing, Bound::finite, Null::refused).value_or(0.0);
    c.load_aiding_a_per_si = r.number(*o, at, aiding, Bound::finite, Null::refused).value_or(0.0);
    c.speed_a_per_si = r.number(*o, at, speed, Bound::finite, Null::refused).value_or(0.0);
    return c;
}

std::optional<CurrentCalibration> read_calibration(ProfileReader& r, const json& model, const std::string& path, OutputKind output) {
    const json* o = r.object(model, path, "calibration", Null::allowed);
    if (!o) return std::nullopt;
    const std::string at = path + "/calibration";
    r.keys(*o, at, {"positive", "negative", "hold_current_a", "residual_sd_a", "samples", "runs_sha256", "calibrated_utc"});
    CurrentCalibration c;
    c.positive = read_coefficients(r, *o, at, "positive", output);
    c.negative = read_coefficients(r, *o, at, "negative", output);
    c.hold_current_a = r.number(*o, at, "hold_current_a", Bound::non_negative, Null::refused).value_or(0.0);
    c.residual_sd_a = r.number(*o, at, "residual_sd_a", Bound::non_negative, Null::refused).value_or(0.0);
    c.samples = r.count(*o, at, "samples", 1).value_or(0);
    for (const auto& [p, e] : r.array(*o, at, "runs_sha256", Null::refused)) {
        const bool hex = e->is_string() && e->get<std::string>().size() == kSha256HexChars &&
                         e->get<std::string>().find_first_not_of("0123456789abcdef") == std::string::npos;
        if (!hex) r.problem(p, "must be a SHA-256 in 64 lowercase hexadecimal digits, not " + e->dump().substr(0, 80));
        else c.runs_sha256.push_back(e->get<std::string>());
    }
    if (o->contains("runs_sha256") && o->at("runs_sha256").is_array() && o->at("runs_sha256").empty()) {
        r.problem(at + "/runs_sha256", "must name at least one healthy run");
    }
    c.calibrated_utc = r.text(*o, at, "calibrated_utc", kMaxNameChars, Null::refused).value_or("");
    return c;
}

void read_drive(ProfileReader& r, const json& root, ActuatorProfile& p) {
    const json* o = r.object(root, "", "drive", Null::refused);
    if (!o) return;
    Drive& d = p.drive;
    const auto kind = r.choice(*o, "/drive", "kind", {"current_controlled", "stepper", "current_not_torque"}, Null::refused);
    if (!kind) return;
    d.kind = static_cast<DriveKind>(*kind);
    const bool controlled = d.kind == DriveKind::current_controlled;
    if (controlled) {
        r.keys(*o, "/drive", {"kind", "supply_v", "resistance_ohm", "inductance_h", "k_t_nm_per_a", "current_limit_a", "torque_limit_nm",
                              "speed_limit_rad_s", "controller"});
    } else {
        r.keys(*o, "/drive", {"kind", "supply_v", "resistance_ohm", "inductance_h", "current_limit_a", "holding_torque_nm",
                              "speed_limit_rad_s", "current_model"});
    }
    d.supply_v = r.number(*o, "/drive", "supply_v", Bound::positive, Null::allowed);
    d.resistance_ohm = r.number(*o, "/drive", "resistance_ohm", Bound::positive, Null::allowed);
    d.inductance_h = r.number(*o, "/drive", "inductance_h", Bound::positive, Null::allowed);
    d.current_limit_a = r.number(*o, "/drive", "current_limit_a", Bound::positive, controlled ? Null::refused : Null::allowed);
    d.speed_limit_rad_s = r.number(*o, "/drive", "speed_limit_rad_s", Bound::positive, Null::allowed);
    if (controlled) {
        d.k_t_nm_per_a = r.number(*o, "/drive", "k_t_nm_per_a", Bound::positive, Null::refused);
        d.torque_limit_nm = r.number(*o, "/drive", "torque_limit_nm", Bound::positive, Null::allowed);
        if (const json* c = r.object(*o, "/drive", "controller", Null::allowed)) {
            r.keys(*c, "/drive/controller", {"position_gain_per_s", "speed_gain_a_s_per_rad", "current_loop", "step_s"});
            Controller k;
            k.position_gain_per_s = r.number(*c, "/drive/controller", "position_gain_per_s", Bound::positive, Null::refused).value_or(0.0);
            k.speed_gain_a_s_per_rad = r.number(*c, "/drive/controller", "speed_gain_a_s_per_rad", Bound::positive, Null::refused).value_or(0.0);
            const auto loop = r.choice(*c, "/drive/controller", "current_loop", {"bang_bang", "pwm"}, Null::refused);
            k.current_loop = loop ? (*loop == 0 ? "bang_bang" : "pwm") : "";
            k.step_s = r.number(*c, "/drive/controller", "step_s", Bound::positive, Null::refused).value_or(0.0);
            d.controller = k;
        }
        return;
    }
    d.holding_torque_nm = r.number(*o, "/drive", "holding_torque_nm", Bound::positive, Null::allowed);
    const json* m = r.object(*o, "/drive", "current_model", Null::refused);
    if (!m) return;
    r.keys(*m, "/drive/current_model", {"form", "calibration"});
    CurrentModel model;
    if (const auto form = r.choice(*m, "/drive/current_model", "form", {kCurrentModelForm}, Null::refused)) model.form = kCurrentModelForm;
    model.calibration = read_calibration(r, *m, "/drive/current_model", p.transmission.output);
    d.current_model = model;
}

void read_friction(ProfileReader& r, const json& t, Friction& f) {
    const json* o = r.object(t, "/transmission", "friction", Null::refused);
    if (!o) return;
    r.keys(*o, "/transmission/friction", {"dynamic_nm", "static_nm", "viscous_nm_s_per_rad"});
    f.dynamic_nm = r.number(*o, "/transmission/friction", "dynamic_nm", Bound::non_negative, Null::allowed);
    f.static_nm = r.number(*o, "/transmission/friction", "static_nm", Bound::non_negative, Null::allowed);
    f.viscous_nm_s_per_rad = r.number(*o, "/transmission/friction", "viscous_nm_s_per_rad", Bound::non_negative, Null::allowed);
    if (f.dynamic_nm && f.static_nm && *f.static_nm < *f.dynamic_nm) {
        r.problem("/transmission/friction/static_nm", "static friction " + o->at("static_nm").dump() + " N m must be >= the dynamic " +
                                                          o->at("dynamic_nm").dump() + " N m");
    }
}

void read_transmission(ProfileReader& r, const json& root, Transmission& t) {
    const json* o = r.object(root, "", "transmission", Null::refused);
    if (!o) return;
    const auto output = r.choice(*o, "/transmission", "output", {"rotary", "linear"}, Null::refused);
    if (!output) return;
    t.output = static_cast<OutputKind>(*output);
    const bool rotary = t.output == OutputKind::rotary;
    if (rotary) {
        r.keys(*o, "/transmission", {"output", "gear_ratio", "screw_lead_m", "efficiency_opposing", "efficiency_aiding", "efficiency_aiding_from",
                                     "inertia_motor_side_kgm2", "end_stops_deg", "friction"});
        t.end_stops_deg = r.interval(*o, "/transmission", "end_stops_deg", Null::allowed);
    } else {
        r.keys(*o, "/transmission", {"output", "gear_ratio", "screw_lead_m", "efficiency_opposing", "efficiency_aiding", "efficiency_aiding_from",
                                     "inertia_motor_side_kgm2", "stroke_m", "end_stops_m", "friction"});
        t.stroke_m = r.number(*o, "/transmission", "stroke_m", Bound::positive, Null::allowed);
        t.end_stops_m = r.interval(*o, "/transmission", "end_stops_m", Null::allowed);
        if (t.stroke_m && t.end_stops_m && t.end_stops_m->second - t.end_stops_m->first < *t.stroke_m) {
            r.problem("/transmission/end_stops_m", "the end stops " + o->at("end_stops_m").dump() + " are closer than the stroke " +
                                                       o->at("stroke_m").dump() + " m");
        }
    }
    t.gear_ratio = r.number(*o, "/transmission", "gear_ratio", Bound::positive, Null::allowed);
    t.screw_lead_m = r.number(*o, "/transmission", "screw_lead_m", Bound::positive, Null::allowed);
    t.efficiency_opposing = r.number(*o, "/transmission", "efficiency_opposing", Bound::efficiency, Null::allowed);
    t.efficiency_aiding = r.number(*o, "/transmission", "efficiency_aiding", Bound::efficiency, Null::allowed);
    if (const auto from = r.choice(*o, "/transmission", "efficiency_aiding_from", {"eq4", "given"}, Null::refused)) {
        t.efficiency_aiding_from = static_cast<EfficiencyAidingFrom>(*from);
    }
    if (t.efficiency_aiding_from == EfficiencyAidingFrom::eq4) {
        const auto given_null = [&](const char* k) { return o->contains(k) && o->at(k).is_null(); };
        if (given_null("efficiency_opposing") || given_null("efficiency_aiding") || given_null("gear_ratio")) {
            r.problem("/transmission/efficiency_aiding_from", "\"eq4\" needs efficiency_opposing, efficiency_aiding and gear_ratio known");
        } else if (t.efficiency_opposing && t.efficiency_aiding && t.gear_ratio) {
            const double eq4 = sim::eta_a_from_eta_o(*t.efficiency_opposing, *t.gear_ratio);  // eq. (4)
            if (std::abs(eq4 - *t.efficiency_aiding) > kEq4Tolerance) {
                r.problem("/transmission/efficiency_aiding", o->at("efficiency_aiding").dump() + " is not eq. (4) of efficiency_opposing " +
                                                                 o->at("efficiency_opposing").dump() + " and gear_ratio " + o->at("gear_ratio").dump() +
                                                                 " (" + json(eq4).dump() + ", tolerance kEq4Tolerance = 5e-7)");
            }
        }
    }
    t.inertia_motor_side_kgm2 = r.number(*o, "/transmission", "inertia_motor_side_kgm2", Bound::positive, Null::allowed);
    read_friction(r, *o, t.friction);
}

void read_sensors(ProfileReader& r, const json& root, Sensors& s) {
    const json* o = r.object(root, "", "sensors", Null::refused);
    if (!o) return;
    r.keys(*o, "/sensors", {"sample_rate_hz", "sampling", "signals"});
    s.sample_rate_hz = r.number(*o, "/sensors", "sample_rate_hz", Bound::positive, Null::refused).value_or(0.0);
    if (const auto sampling = r.choice(*o, "/sensors", "sampling", {"period_mean", "instant"}, Null::refused)) {
        s.sampling = static_cast<Sampling>(*sampling);
    }
    const auto entries = r.array(*o, "/sensors", "signals", Null::refused);
    if (o->contains("signals") && o->at("signals").is_array() && entries.empty()) r.problem("/sensors/signals", "must list at least one signal");
    std::set<std::string> names;
    for (const auto& [path, e] : entries) {
        if (!e->is_object()) {
            r.problem(path, "must be an object");
            continue;
        }
        r.keys(*e, path, {"signal", "unit", "resolution", "noise_sd", "source"});
        SensorSignal sig;
        sig.signal = r.text(*e, path, "signal", kMaxSignalChars, Null::refused).value_or("");
        if (!sig.signal.empty() && !signal_name_ok(sig.signal)) {
            r.problem(path + "/signal", "'" + sig.signal + "' must be a lowercase letter, then lowercase letters, digits or '_'");
        } else if (!sig.signal.empty() && !names.insert(sig.signal).second) {
            r.problem(path + "/signal", "'" + sig.signal + "' is listed twice");
        }
        if (const auto unit = r.text(*e, path, "unit", kMaxNameChars, Null::refused)) {
            if (!measured::find_unit(*unit)) r.problem(path + "/unit", "unknown unit '" + *unit + "' (known units: " + measured::known_units_text() + ")");
            sig.unit = *unit;
        }
        sig.resolution = r.number(*e, path, "resolution", Bound::positive, Null::allowed);
        sig.noise_sd = r.number(*e, path, "noise_sd", Bound::non_negative, Null::allowed);
        sig.source = r.text(*e, path, "source", kMaxTextChars, Null::allowed).value_or("");
        s.signals.push_back(sig);
    }
}

void read_load(ProfileReader& r, const json& root, ActuatorProfile& p) {
    const json* o = r.object(root, "", "load", Null::refused);
    if (!o) return;
    Load& l = p.load;
    r.keys(*o, "/load", {"quantity", "side", "positive", "description", "measured_by", "signal"});
    if (const auto q = r.choice(*o, "/load", "quantity", {"torque", "force"}, Null::refused)) {
        l.quantity = static_cast<LoadQuantity>(*q);
        const LoadQuantity expected = p.transmission.output == OutputKind::rotary ? LoadQuantity::torque : LoadQuantity::force;
        if (l.quantity != expected) {
            r.problem("/load/quantity", "the load on a " + std::string(to_string(p.transmission.output)) + " output is a " +
                                            (expected == LoadQuantity::torque ? "torque" : "force") + ", not " + o->at("quantity").dump());
        }
    }
    if (const auto side = r.choice(*o, "/load", "side", {"output", "motor"}, Null::refused)) l.side = static_cast<LoadSide>(*side);
    if (const auto pos = r.choice(*o, "/load", "positive", {"resists_positive_motion", "aids_positive_motion"}, Null::allowed)) {
        l.positive = static_cast<LoadPositive>(*pos);
    }
    (void)r.text(*o, "/load", "description", kMaxTextChars, Null::allowed);
    if (const auto by = r.choice(*o, "/load", "measured_by", {"sensor", "set_point"}, Null::refused)) l.measured_by = static_cast<LoadMeasuredBy>(*by);
    l.signal = r.text(*o, "/load", "signal", kMaxSignalChars, Null::allowed);
    if (l.measured_by != LoadMeasuredBy::sensor || !o->contains("measured_by")) return;
    if (!l.signal) {
        if (o->contains("signal")) r.problem("/load/signal", "a load measured by a sensor names that sensor's signal, not null");
        return;
    }
    const SensorSignal* s = p.sensors.find(*l.signal);
    if (!s) {
        r.problem("/load/signal", "'" + *l.signal + "' is not a signal of /sensors/signals");
        return;
    }
    const auto unit = measured::find_unit(s->unit);
    const auto want = l.quantity == LoadQuantity::torque ? measured::Quantity::torque : measured::Quantity::force;
    if (unit && unit->quantity != want) {
        r.problem("/load/signal", "the sensor '" + *l.signal + "' is in '" + s->unit + "', not a unit of " +
                                      std::string(measured::quantity_name(want)));
    }
}

}  // namespace

ActuatorProfile parse_actuator_profile(std::string_view json_text, const std::string& source) {
    std::string error;
    const auto parsed = io::parse_bounded_json(json_text, error);
    if (!parsed) throw ActuatorError("actuator profile " + source + ": " + error);
    const json& root = *parsed;
    ProfileReader r(source);
    if (!root.is_object()) {
        r.problem("", "must be a JSON object");
        r.throw_if_any();
    }
    ActuatorProfile p;
    p.path = source;
    p.sha256 = db::sha256_hex(json_text);
    r.keys(root, "", {"schema", "identity", "drive", "transmission", "sensors", "load", "operations"});
    if (const auto schema = r.text(root, "", "schema", kMaxNameChars, Null::refused); schema && *schema != kActuatorProfileSchema) {
        r.problem("/schema", "'" + *schema + "' is not '" + std::string(kActuatorProfileSchema) + "'");
    }
    read_identity(r, root, p);
    read_transmission(r, root, p.transmission);  // before the drive and the load: their units follow the output
    read_drive(r, root, p);
    read_sensors(r, root, p.sensors);
    read_load(r, root, p);
    detail::read_operations(r, root, p);
    r.throw_if_any();
    p.document = root;
    return p;
}

ActuatorProfile load_actuator_profile(const std::string& path) {
    std::error_code ec;
    const auto status = std::filesystem::status(path, ec);
    if (ec || !std::filesystem::exists(status)) throw ActuatorError("actuator profile " + path + ": no such file");
    if (!std::filesystem::is_regular_file(status)) throw ActuatorError("actuator profile " + path + ": not a regular file");
    // Read the bytes once: the hash is of exactly the text parsed.
    std::string text, error;
    if (!io::read_bounded_text_file(path, text, error)) throw ActuatorError("actuator profile " + path + ": " + error);
    return parse_actuator_profile(text, path);
}

}  // namespace emadiag::actuator
