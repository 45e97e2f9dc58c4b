#pragma once
// The actuator as data (issue 23 part 1; schema in docs/actuator-profile.md): one actuator's
// identity, drive, transmission, sensors, load and operations, read from a profile file and checked
// once by load_actuator_profile. Every physical value carries its unit in its field name (as in the
// code: k_t_nm_per_a); a value the actuator's documentation does not give is null in the file, an
// empty optional here (unknown, never invented). Every problem of a file is listed at once, each as
// "FILE: /json/path: message" naming the value and the allowed range.
#include <nlohmann/json.hpp>

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace emadiag::actuator {

/// The schema name a profile carries in "schema".
inline constexpr const char* kActuatorProfileSchema = "emadiag-actuator-profile/1";
/// The profile a command uses when --actuator is not given.
inline constexpr const char* kDefaultPartNumber = "EMA-REF-1";
/// Longest part number ([A-Za-z0-9][A-Za-z0-9._+-]*: also a safe file-name part).
inline constexpr std::size_t kMaxPartNumberChars = 64;
/// Longest name, signal, sequence or message name.
inline constexpr std::size_t kMaxNameChars = 200;
/// Longest free text (description, source).
inline constexpr std::size_t kMaxTextChars = 4096;
/// Most entries of one array (sensors, sequences, load cases, priors, messages, coefficients).
inline constexpr std::size_t kMaxProfileEntries = 64;
/// How far a datasheet eta_A may be from eq. (4) of eta_O when "efficiency_aiding_from" is "eq4":
/// half a unit of the sixth decimal (the datasheet prints 0.823788).
inline constexpr double kEq4Tolerance = 5e-7;

/// A value the documentation gives, or null (unknown) in the file.
using MaybeNumber = std::optional<double>;

enum class DriveKind { current_controlled, stepper, current_not_torque };
enum class OutputKind { rotary, linear };
enum class Sampling { period_mean, instant };
enum class LoadQuantity { torque, force };
enum class LoadSide { output, motor };
enum class LoadPositive { resists_positive_motion, aids_positive_motion };
enum class LoadMeasuredBy { sensor, set_point };
enum class EfficiencyAidingFrom { eq4, given };
enum class SequenceKind { polynomial, breakaway, trapezoid };
enum class LoadCaseKind { constant, ramp, aircraft_linear_model };
enum class PriorDistribution { uniform, eq4_inverse_of_eta_a };

[[nodiscard]] const char* to_string(DriveKind k);
[[nodiscard]] const char* to_string(OutputKind k);
[[nodiscard]] const char* to_string(LoadMeasuredBy k);

/// A current-controlled drive's loops (ema-reference.md section 3 steps 2 and 3).
struct Controller {
    double position_gain_per_s = 0;
    double speed_gain_a_s_per_rad = 0;
    std::string current_loop;  ///< "bang_bang" or "pwm"
    double step_s = 0;
};

/// One direction's coefficients of the empirical current model "linear_load_speed/1" (load in the
/// output's SI unit: N for a linear output, N m for a rotary one; speed in m/s or rad/s).
struct CurrentCoefficients {
    double i0_a = 0;
    double load_opposing_a_per_si = 0;
    double load_aiding_a_per_si = 0;
    double speed_a_per_si = 0;
};

/// What a calibration on the unit's healthy runs stores.
struct CurrentCalibration {
    CurrentCoefficients positive;          ///< moving in the positive direction
    CurrentCoefficients negative;
    double hold_current_a = 0;             ///< at rest
    double residual_sd_a = 0;
    std::size_t samples = 0;
    std::vector<std::string> runs_sha256;  ///< the healthy runs it was fitted on
    std::string calibrated_utc;
};

/// The empirical current model of a drive whose current is not torque (docs/actuator-profile.md).
struct CurrentModel {
    std::string form;                                ///< "linear_load_speed/1"
    std::optional<CurrentCalibration> calibration;   ///< none until calibrated
};

struct Drive {
    DriveKind kind = DriveKind::current_controlled;
    MaybeNumber supply_v, resistance_ohm, inductance_h;
    MaybeNumber k_t_nm_per_a;       ///< current_controlled only (known)
    MaybeNumber current_limit_a;
    MaybeNumber torque_limit_nm;    ///< current_controlled only
    MaybeNumber holding_torque_nm;  ///< stepper / current_not_torque only
    MaybeNumber speed_limit_rad_s;
    std::optional<Controller> controller;     ///< current_controlled only
    std::optional<CurrentModel> current_model; ///< stepper / current_not_torque only
};

struct Friction {
    MaybeNumber dynamic_nm, static_nm, viscous_nm_s_per_rad;  ///< motor side
};

struct Transmission {
    OutputKind output = OutputKind::rotary;
    MaybeNumber gear_ratio;              ///< motor angle / output angle (or / screw angle)
    MaybeNumber screw_lead_m;            ///< output travel per screw revolution
    MaybeNumber efficiency_opposing, efficiency_aiding;
    EfficiencyAidingFrom efficiency_aiding_from = EfficiencyAidingFrom::given;
    MaybeNumber inertia_motor_side_kgm2;
    std::optional<std::pair<double, double>> end_stops_deg;  ///< rotary
    MaybeNumber stroke_m;                                    ///< linear
    std::optional<std::pair<double, double>> end_stops_m;    ///< linear
    Friction friction;
};

struct SensorSignal {
    std::string signal;
    std::string unit;         ///< a unit of src/measured/units.hpp
    MaybeNumber resolution;   ///< in `unit`
    MaybeNumber noise_sd;     ///< standard deviation, in `unit`
    std::string source;
};

struct Sensors {
    double sample_rate_hz = 0;
    Sampling sampling = Sampling::instant;
    std::vector<SensorSignal> signals;
    [[nodiscard]] const SensorSignal* find(std::string_view name) const;
};

struct Load {
    LoadQuantity quantity = LoadQuantity::torque;
    LoadSide side = LoadSide::output;
    std::optional<LoadPositive> positive;  ///< unknown when null
    LoadMeasuredBy measured_by = LoadMeasuredBy::sensor;
    std::optional<std::string> signal;     ///< the sensor (sensor), or the run's set-point signal
};

struct Sequence {
    std::string name;
    SequenceKind kind = SequenceKind::polynomial;
    nlohmann::json parameters;  ///< the entry as checked (kind-specific fields, in their units)
};

struct LoadCase {
    std::string name;
    LoadCaseKind kind = LoadCaseKind::constant;
    nlohmann::json parameters;
};

struct HealthPrior {
    std::string parameter;  ///< FDJ_Nm, FSJ_Nm, eta_A, eta_O
    double nominal = 0;
    MaybeNumber min, max;
    PriorDistribution distribution = PriorDistribution::uniform;
};

struct CanIcd {
    std::string dbc;                    ///< relative to the data folder (share/emadiag)
    std::vector<std::string> messages;
};

struct Operations {
    std::vector<Sequence> sequences;
    std::vector<LoadCase> load_cases;
    MaybeNumber limit_current_a, limit_speed_rad_s, limit_torque_nm;
    std::vector<HealthPrior> health_priors;
    std::optional<CanIcd> can_icd;  ///< none: the actuator has no CAN ICD
    [[nodiscard]] const HealthPrior* prior(std::string_view parameter) const;
};

struct ActuatorProfile {
    std::string path;     ///< the file ("" when parsed from text)
    std::string sha256;   ///< of the file's bytes
    std::string part_number, name, description;
    Drive drive;
    Transmission transmission;
    Sensors sensors;
    Load load;
    Operations operations;
    nlohmann::json document;  ///< the file as read, for `actuator show`
};

/// Reads and checks a profile file (at most io::kMaxJsonBytes, a regular file). Throws ActuatorError
/// listing every problem as "PATH: /field: message".
[[nodiscard]] ActuatorProfile load_actuator_profile(const std::string& path);
/// The same from text; `source` names it in messages.
[[nodiscard]] ActuatorProfile parse_actuator_profile(std::string_view json_text, const std::string& source);

/// The unit of a numeric field, from its name's suffix ("k_t_nm_per_a" -> "N m/A"); "" for a
/// dimensionless field (ratio, efficiency, count); nullopt for a name the table does not know.
[[nodiscard]] std::optional<std::string> unit_of_field(std::string_view field);

/// The profile as "/json/path = value unit" lines (null: "unknown"), every leaf of the file, keys sorted.
[[nodiscard]] std::vector<std::string> describe_profile(const ActuatorProfile& profile);

/// The JSON paths of the values the profile marks unknown (null), in file order.
[[nodiscard]] std::vector<std::string> unknown_fields(const ActuatorProfile& profile);

}  // namespace emadiag::actuator
