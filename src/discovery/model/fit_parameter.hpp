#pragma once
// The parameters a re-simulation fit varies (resimulation.hpp), by a typed id: FDJ, eta_O (eta_A
// follows it by eq. 4), an effect of sim::Effects that discovery fits, or the coefficient of one term
// of EmaParams::terms by its index. fit_parameter_name is the one printer, for what reports and JSON
// show: "fdj_nm", "eta_o", the sim::Effects name ("stribeck_amplitude"), "term:K".
#include "emadiag/sim/ema_params.hpp"

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace emadiag::discovery {

/// The sim::Effects that discovery fits (fit_parameter.cpp holds each one's finite-difference step
/// and the range a fit keeps it in).
enum class FittedEffect : std::uint8_t {
    Viscous,
    StribeckAmplitude,
    StribeckSpeed,
    SpallAmplitude,
    SpallCenter,
    SpallWidth,
    RippleAmplitude,
    CurrentGainError,
    HingeOffset,
    TrueInertia,
};
inline constexpr std::size_t kFittedEffectCount = 10;

/// The sim::Effects name of `e` ("stribeck_amplitude").
[[nodiscard]] const char* effect_name(FittedEffect e);

class FitParameter {
public:
    enum class Kind : std::uint8_t { Fdj, EtaO, Effect, Term };

    [[nodiscard]] static constexpr FitParameter fdj() { return {Kind::Fdj, 0}; }
    [[nodiscard]] static constexpr FitParameter eta_o() { return {Kind::EtaO, 0}; }
    [[nodiscard]] static constexpr FitParameter effect(FittedEffect e) { return {Kind::Effect, static_cast<std::size_t>(e)}; }
    /// The coefficient of EmaParams::terms[index].
    [[nodiscard]] static constexpr FitParameter term(std::size_t index) { return {Kind::Term, index}; }

    [[nodiscard]] constexpr Kind kind() const { return kind_; }
    /// FDJ or eta_O (the health parameters a fit refits beside an effect).
    [[nodiscard]] constexpr bool is_health() const { return kind_ == Kind::Fdj || kind_ == Kind::EtaO; }
    /// Only for kind() == Effect.
    [[nodiscard]] constexpr FittedEffect fitted_effect() const { return static_cast<FittedEffect>(index_); }
    /// Only for kind() == Term.
    [[nodiscard]] constexpr std::size_t term_index() const { return index_; }

    friend constexpr bool operator==(const FitParameter&, const FitParameter&) = default;

private:
    constexpr FitParameter(Kind kind, std::size_t index) : kind_(kind), index_(index) {}
    Kind kind_;
    std::size_t index_;
};

/// The one printer: "fdj_nm", "eta_o", the sim::Effects name, "term:K". Nothing parses these names
/// back: code passes FitParameter.
[[nodiscard]] std::string fit_parameter_name(const FitParameter& p);

/// The range a fit keeps one parameter in (effects: inside sim::Effects::range, narrowed only where
/// fit_parameter.cpp says why).
struct FitRange {
    double lo;
    double hi;
};
[[nodiscard]] FitRange fit_range(const FitParameter& parameter);
/// The smallest finite-difference step of a fit along the parameter (resimulation.cpp steps by a
/// fraction of the value, at least this).
[[nodiscard]] double fit_step_floor(const FitParameter& parameter);
/// The effects (sim::Effects names) that discovery fits.
[[nodiscard]] std::vector<std::string> fitted_effect_names();
/// Reads / writes one fittable parameter of EmaParams (eta_o also sets eta_a by eq. 4; a value is kept
/// inside fit_range). A term index beyond the model's terms throws EmadiagError.
[[nodiscard]] double get_parameter(const sim::EmaParams& p, const FitParameter& parameter);
void set_parameter(sim::EmaParams& p, const FitParameter& parameter, double value);

}  // namespace emadiag::discovery
