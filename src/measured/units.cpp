#include "measured/units.hpp"

#include <array>
#include <numbers>

namespace emadiag::measured {

namespace {

constexpr double kStandardGravity_m_s2 = 9.80665;       // kgf -> N (CGPM 1901)
constexpr double kPoundForce_n = 4.4482216152605;       // lbf -> N
constexpr double kInch_m = 0.0254;
constexpr double kCelsiusOffset_k = 273.15;

constexpr std::array<Unit, 38> kUnits{{
    {"s", Quantity::time, 1.0, 0.0},
    {"ms", Quantity::time, 1e-3, 0.0},
    {"us", Quantity::time, 1e-6, 0.0},
    {"min", Quantity::time, 60.0, 0.0},
    {"m", Quantity::length, 1.0, 0.0},
    {"mm", Quantity::length, 1e-3, 0.0},
    {"cm", Quantity::length, 1e-2, 0.0},
    {"um", Quantity::length, 1e-6, 0.0},
    {"in", Quantity::length, kInch_m, 0.0},
    {"rad", Quantity::angle, 1.0, 0.0},
    {"deg", Quantity::angle, std::numbers::pi / 180.0, 0.0},
    {"rev", Quantity::angle, 2.0 * std::numbers::pi, 0.0},
    {"A", Quantity::current, 1.0, 0.0},
    {"mA", Quantity::current, 1e-3, 0.0},
    {"V", Quantity::voltage, 1.0, 0.0},
    {"mV", Quantity::voltage, 1e-3, 0.0},
    {"N", Quantity::force, 1.0, 0.0},
    {"kN", Quantity::force, 1e3, 0.0},
    {"kgf", Quantity::force, kStandardGravity_m_s2, 0.0},
    {"lbf", Quantity::force, kPoundForce_n, 0.0},
    {"N.m", Quantity::torque, 1.0, 0.0},
    {"Nm", Quantity::torque, 1.0, 0.0},
    {"mN.m", Quantity::torque, 1e-3, 0.0},
    {"m/s", Quantity::linear_speed, 1.0, 0.0},
    {"mm/s", Quantity::linear_speed, 1e-3, 0.0},
    {"rad/s", Quantity::angular_speed, 1.0, 0.0},
    {"deg/s", Quantity::angular_speed, std::numbers::pi / 180.0, 0.0},
    {"rpm", Quantity::angular_speed, 2.0 * std::numbers::pi / 60.0, 0.0},
    {"m/s2", Quantity::linear_acceleration, 1.0, 0.0},
    {"mm/s2", Quantity::linear_acceleration, 1e-3, 0.0},
    {"rad/s2", Quantity::angular_acceleration, 1.0, 0.0},
    {"deg/s2", Quantity::angular_acceleration, std::numbers::pi / 180.0, 0.0},
    {"K", Quantity::temperature, 1.0, 0.0},
    {"degC", Quantity::temperature, 1.0, kCelsiusOffset_k},
    {"1", Quantity::dimensionless, 1.0, 0.0},
    {"%", Quantity::dimensionless, 1e-2, 0.0},
    {"lbf.in", Quantity::torque, kPoundForce_n * kInch_m, 0.0},
    {"kN.m", Quantity::torque, 1e3, 0.0},
}};

struct QuantityInfo {
    Quantity quantity;
    std::string_view name;
    std::string_view si;
};

constexpr std::array<QuantityInfo, 13> kQuantities{{
    {Quantity::time, "time", "s"},
    {Quantity::length, "length", "m"},
    {Quantity::angle, "angle", "rad"},
    {Quantity::current, "current", "A"},
    {Quantity::voltage, "voltage", "V"},
    {Quantity::force, "force", "N"},
    {Quantity::torque, "torque", "N.m"},
    {Quantity::linear_speed, "linear_speed", "m/s"},
    {Quantity::angular_speed, "angular_speed", "rad/s"},
    {Quantity::linear_acceleration, "linear_acceleration", "m/s2"},
    {Quantity::angular_acceleration, "angular_acceleration", "rad/s2"},
    {Quantity::temperature, "temperature", "K"},
    {Quantity::dimensionless, "dimensionless", "1"},
}};

}  // namespace

std::optional<Unit> find_unit(std::string_view name) {
    for (const Unit& u : kUnits) {
        if (u.name == name) return u;
    }
    return std::nullopt;
}

std::string known_units_text() {
    std::string out;
    for (const QuantityInfo& q : kQuantities) {
        if (!out.empty()) out += "; ";
        out += std::string(q.name) + ":";
        bool first = true;
        for (const Unit& u : kUnits) {
            if (u.quantity != q.quantity) continue;
            out += first ? " " : ", ";
            out += u.name;
            first = false;
        }
    }
    return out;
}

std::string_view quantity_name(Quantity q) {
    for (const QuantityInfo& i : kQuantities) {
        if (i.quantity == q) return i.name;
    }
    return "?";
}

std::optional<Quantity> parse_quantity(std::string_view name) {
    for (const QuantityInfo& i : kQuantities) {
        if (i.name == name) return i.quantity;
    }
    return std::nullopt;
}

std::string_view si_unit(Quantity q) {
    for (const QuantityInfo& i : kQuantities) {
        if (i.quantity == q) return i.si;
    }
    return "?";
}

std::optional<Quantity> derivative_quantity(Quantity q) {
    switch (q) {
        case Quantity::length: return Quantity::linear_speed;
        case Quantity::linear_speed: return Quantity::linear_acceleration;
        case Quantity::angle: return Quantity::angular_speed;
        case Quantity::angular_speed: return Quantity::angular_acceleration;
        default: return std::nullopt;
    }
}

}  // namespace emadiag::measured
