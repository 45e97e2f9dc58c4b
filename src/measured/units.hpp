#pragma once
// The units a column map may name, per physical quantity, and their conversion to SI
// (docs/column-map.md, "Units"): si = factor * value + offset (the offset is non-zero for degC only).
#include <optional>
#include <string>
#include <string_view>

namespace emadiag::measured {

enum class Quantity {
    time,
    length,
    angle,
    current,
    voltage,
    force,
    torque,
    linear_speed,
    angular_speed,
    linear_acceleration,
    angular_acceleration,
    temperature,
    dimensionless,
};

struct Unit {
    std::string_view name;    ///< as written in a map: "mm", "kgf", "deg"
    Quantity quantity;
    double factor;            ///< SI per unit
    double offset;            ///< added after the factor (degC -> K)
};

/// The unit of that name (exact, case-sensitive: "mA" is not "MA"); nullopt when unknown.
[[nodiscard]] std::optional<Unit> find_unit(std::string_view name);
/// Every known unit, grouped by quantity: "time: s, ms, us, min; length: m, mm, ...".
[[nodiscard]] std::string known_units_text();
/// The quantity's name as written in a map and in messages ("linear_speed").
[[nodiscard]] std::string_view quantity_name(Quantity q);
[[nodiscard]] std::optional<Quantity> parse_quantity(std::string_view name);
/// The SI unit a signal of that quantity is held in ("m", "m/s", "A", "N", "K", "1").
[[nodiscard]] std::string_view si_unit(Quantity q);
/// The quantity of a signal's time derivative (length -> linear_speed); nullopt when the import
/// does not differentiate that quantity.
[[nodiscard]] std::optional<Quantity> derivative_quantity(Quantity q);

}  // namespace emadiag::measured
