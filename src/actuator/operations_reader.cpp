#include "actuator/operations_reader.hpp"

#include <optional>
#include <set>
#include <string>

namespace emadiag::actuator::detail {

using nlohmann::json;

namespace {

/// Most coefficients of a polynomial command (degree 7).
constexpr std::size_t kMaxPolynomialCoefficients = 8;
/// Largest state of an aircraft model.
constexpr std::size_t kMaxAircraftStates = 8;

/// The name (unique within its array, no blank at either end) and the kind of a sequence or a load
/// case; nullopt when either is wrong (with the keys checked against the common ones).
std::optional<std::pair<std::string, std::size_t>> entry_head(ProfileReader& r, const std::string& path, const json& e,
                                                              const std::vector<const char*>& kinds, std::set<std::string>& seen) {
    const auto name = r.text(e, path, "name", kMaxNameChars, Null::refused);
    if (name && (name->front() == ' ' || name->back() == ' ')) r.problem(path + "/name", "'" + *name + "' must not start or end with a space");
    if (name && !seen.insert(*name).second) r.problem(path + "/name", "'" + *name + "' is named twice");
    const auto kind = r.choice(e, path, "kind", kinds, Null::refused);
    if (!name || !kind) {
        r.keys(e, path, {"name", "kind", "description"});
        return std::nullopt;
    }
    return std::make_pair(*name, *kind);
}

void read_sequence(ProfileReader& r, const std::string& path, const json& e, OutputKind output, std::set<std::string>& names, Operations& ops) {
    const auto head = entry_head(r, path, e, {"polynomial", "breakaway", "trapezoid"}, names);
    if (!head) return;
    Sequence s;
    s.name = head->first;
    s.kind = static_cast<SequenceKind>(head->second);
    const bool rotary = output == OutputKind::rotary;
    switch (s.kind) {
        case SequenceKind::polynomial: {
            const char* coefficients = rotary ? "coefficients_deg" : "coefficients_m";
            r.keys(e, path, {"name", "kind", "description", "duration_s", coefficients});
            (void)r.number(e, path, "duration_s", Bound::positive, Null::refused);
            if (e.contains(coefficients)) (void)r.numbers(e.at(coefficients), path + "/" + coefficients, kMaxPolynomialCoefficients);
            break;
        }
        case SequenceKind::breakaway:
            r.keys(e, path, {"name", "kind", "description", "duration_s", "first_hold_s", "ramp_a_per_s", "move_rad", "mid_hold_s"});
            for (const char* k : {"duration_s", "first_hold_s", "ramp_a_per_s", "move_rad", "mid_hold_s"}) {
                (void)r.number(e, path, k, Bound::positive, Null::refused);
            }
            break;
        case SequenceKind::trapezoid: {
            const char* stroke = rotary ? "stroke_deg" : "stroke_m";
            const char* speed = rotary ? "speed_deg_s" : "speed_m_s";
            r.keys(e, path, {"name", "kind", "description", stroke, speed, "dwell_s", "cycles"});
            (void)r.number(e, path, stroke, Bound::positive, Null::refused);
            (void)r.number(e, path, speed, Bound::positive, Null::refused);
            (void)r.number(e, path, "dwell_s", Bound::non_negative, Null::refused);
            (void)r.count(e, path, "cycles", 1);
            break;
        }
    }
    (void)r.text(e, path, "description", kMaxTextChars, Null::allowed);
    s.parameters = e;
    ops.sequences.push_back(s);
}

void read_aircraft_model(ProfileReader& r, const std::string& path, const json& e) {
    r.keys(e, path, {"name", "kind", "description", "state_matrix", "input_matrix", "step_s", "trim_elevator_deg", "dynamic_pressure_pa",
                     "elevator_area_m2", "elevator_chord_m", "hinge_coefficient_alpha_per_rad", "hinge_coefficient_delta_per_rad",
                     "tail_arm_m", "airspeed_m_s"});
    std::size_t states = 0;
    if (const auto it = e.find("state_matrix"); it != e.end()) {
        const bool rows_ok = it->is_array() && !it->empty() && it->size() <= kMaxAircraftStates;
        if (!rows_ok) r.problem(path + "/state_matrix", "must be an array of 1 to " + std::to_string(kMaxAircraftStates) + " rows");
        for (std::size_t i = 0; rows_ok && i < it->size(); ++i) {
            const auto row = r.numbers((*it)[i], path + "/state_matrix/" + std::to_string(i), kMaxAircraftStates);
            if (row && row->size() != it->size()) {
                r.problem(path + "/state_matrix/" + std::to_string(i), "a square matrix of " + std::to_string(it->size()) + " rows has " +
                                                                           std::to_string(it->size()) + " columns, not " + std::to_string(row->size()));
            }
        }
        if (rows_ok) states = it->size();
    }
    if (e.contains("input_matrix")) {
        const auto b = r.numbers(e.at("input_matrix"), path + "/input_matrix", kMaxAircraftStates);
        if (b && states > 0 && b->size() != states) {
            r.problem(path + "/input_matrix", "must have one entry per state (" + std::to_string(states) + "), not " + std::to_string(b->size()));
        }
    }
    for (const char* k : {"step_s", "dynamic_pressure_pa", "elevator_area_m2", "elevator_chord_m", "tail_arm_m", "airspeed_m_s"}) {
        (void)r.number(e, path, k, Bound::positive, Null::refused);
    }
    for (const char* k : {"trim_elevator_deg", "hinge_coefficient_alpha_per_rad", "hinge_coefficient_delta_per_rad"}) {
        (void)r.number(e, path, k, Bound::finite, Null::refused);
    }
}

void read_load_case(ProfileReader& r, const std::string& path, const json& e, OutputKind output, std::set<std::string>& names, Operations& ops) {
    const auto head = entry_head(r, path, e, {"constant", "ramp", "aircraft_linear_model"}, names);
    if (!head) return;
    LoadCase c;
    c.name = head->first;
    c.kind = static_cast<LoadCaseKind>(head->second);
    const bool rotary = output == OutputKind::rotary;
    const char* load = rotary ? "load_nm" : "load_n";
    const char* rate = rotary ? "rate_nm_per_s" : "rate_n_per_s";
    switch (c.kind) {
        case LoadCaseKind::constant:
            r.keys(e, path, {"name", "kind", "description", load});
            (void)r.number(e, path, load, Bound::finite, Null::refused);
            break;
        case LoadCaseKind::ramp:
            r.keys(e, path, {"name", "kind", "description", load, rate});
            (void)r.number(e, path, load, Bound::finite, Null::refused);
            (void)r.number(e, path, rate, Bound::finite, Null::refused);
            break;
        case LoadCaseKind::aircraft_linear_model:
            if (!rotary) r.problem(path + "/kind", "an aircraft model loads a rotary output (a control surface), not a linear one");
            read_aircraft_model(r, path, e);
            break;
    }
    (void)r.text(e, path, "description", kMaxTextChars, Null::allowed);
    c.parameters = e;
    ops.load_cases.push_back(c);
}

void read_prior(ProfileReader& r, const std::string& path, const json& e, std::set<std::string>& names, Operations& ops) {
    r.keys(e, path, {"parameter", "nominal", "min", "max", "distribution"});
    HealthPrior h;
    const std::vector<const char*> params = {"FDJ_Nm", "FSJ_Nm", "eta_A", "eta_O"};
    const auto param = r.choice(e, path, "parameter", params, Null::refused);
    if (!param) return;
    h.parameter = params[*param];
    if (!names.insert(h.parameter).second) r.problem(path + "/parameter", "'" + h.parameter + "' has two priors");
    const Bound bound = h.parameter.starts_with("eta") ? Bound::efficiency : Bound::non_negative;
    h.nominal = r.number(e, path, "nominal", bound, Null::refused).value_or(0.0);
    const auto dist = r.choice(e, path, "distribution", {"uniform", "eq4_inverse_of_eta_A"}, Null::refused);
    if (!dist) return;
    h.distribution = static_cast<PriorDistribution>(*dist);
    if (h.distribution == PriorDistribution::uniform) {
        h.min = r.number(e, path, "min", bound, Null::refused);
        h.max = r.number(e, path, "max", bound, Null::refused);
        if (h.min && h.max && !(*h.min <= h.nominal && h.nominal <= *h.max)) {
            r.problem(path, "the nominal " + e.at("nominal").dump() + " must be in [min, max] = [" + e.at("min").dump() + ", " + e.at("max").dump() + "]");
        }
    } else {
        if (h.parameter != "eta_O") r.problem(path + "/distribution", "\"eq4_inverse_of_eta_A\" is the prior of eta_O only, not of " + h.parameter);
        for (const char* k : {"min", "max"}) {
            if (e.contains(k) && !e.at(k).is_null()) r.problem(path + "/" + k, "must be null: eq. (4) gives it from the eta_A prior, not " + e.at(k).dump());
        }
    }
    ops.health_priors.push_back(h);
}

void read_can_icd(ProfileReader& r, const json& o, Operations& ops) {
    const json* c = r.object(o, "/operations", "can_icd", Null::allowed);
    if (!c) return;
    r.keys(*c, "/operations/can_icd", {"dbc", "messages"});
    CanIcd icd;
    if (const auto dbc = r.text(*c, "/operations/can_icd", "dbc", kMaxNameChars, Null::refused)) {
        if (dbc->front() == '/' || dbc->find("..") != std::string::npos) {
            r.problem("/operations/can_icd/dbc", "'" + *dbc + "' must be a path inside the data folder (relative, without '..')");
        }
        icd.dbc = *dbc;
    }
    std::set<std::string> seen;
    for (const auto& [path, m] : r.array(*c, "/operations/can_icd", "messages", Null::refused)) {
        const bool ok = m->is_string() && !m->get<std::string>().empty() && m->get<std::string>().size() <= kMaxNameChars &&
                        m->get<std::string>().find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_") == std::string::npos;
        if (!ok) r.problem(path, "must be a DBC message name (letters, digits, '_'), not " + m->dump().substr(0, 80));
        else if (!seen.insert(m->get<std::string>()).second) r.problem(path, m->dump() + " is listed twice");
        else icd.messages.push_back(m->get<std::string>());
    }
    if (c->contains("messages") && icd.messages.empty() && c->at("messages").is_array() && c->at("messages").empty()) {
        r.problem("/operations/can_icd/messages", "must name at least one message");
    }
    ops.can_icd = icd;
}

}  // namespace

void read_operations(ProfileReader& r, const json& root, ActuatorProfile& p) {
    const json* o = r.object(root, "", "operations", Null::refused);
    if (!o) return;
    Operations& ops = p.operations;
    const OutputKind output = p.transmission.output;
    r.keys(*o, "/operations", {"sequences", "load_cases", "limits", "health_priors", "can_icd"});
    std::set<std::string> names;
    for (const auto& [path, e] : r.array(*o, "/operations", "sequences", Null::refused)) {
        if (e->is_object()) read_sequence(r, path, *e, output, names, ops);
        else r.problem(path, "must be an object");
    }
    names.clear();
    for (const auto& [path, e] : r.array(*o, "/operations", "load_cases", Null::refused)) {
        if (e->is_object()) read_load_case(r, path, *e, output, names, ops);
        else r.problem(path, "must be an object");
    }
    if (const json* l = r.object(*o, "/operations", "limits", Null::refused)) {
        r.keys(*l, "/operations/limits", {"current_a", "speed_rad_s", "torque_nm"});
        ops.limit_current_a = r.number(*l, "/operations/limits", "current_a", Bound::positive, Null::allowed);
        ops.limit_speed_rad_s = r.number(*l, "/operations/limits", "speed_rad_s", Bound::positive, Null::allowed);
        ops.limit_torque_nm = r.number(*l, "/operations/limits", "torque_nm", Bound::positive, Null::allowed);
    }
    names.clear();
    for (const auto& [path, e] : r.array(*o, "/operations", "health_priors", Null::refused)) {
        if (e->is_object()) read_prior(r, path, *e, names, ops);
        else r.problem(path, "must be an object");
    }
    const HealthPrior* eta_o = ops.prior("eta_O");
    if (eta_o && eta_o->distribution == PriorDistribution::eq4_inverse_of_eta_a) {
        const HealthPrior* eta_a = ops.prior("eta_A");
        if (!eta_a || eta_a->distribution != PriorDistribution::uniform) {
            r.problem("/operations/health_priors", "the eta_O prior from eq. (4) needs a uniform eta_A prior");
        }
    }
    read_can_icd(r, *o, ops);
}

}  // namespace emadiag::actuator::detail
