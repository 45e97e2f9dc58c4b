#pragma once
// Parameters of the reference actuator EMA-REF-1 (ema-reference.md section 1) and the
// effects beyond the datasheet (issue 2 part 5). Every field is validated; JSON in and out.
#include "emadiag/sim/physics.hpp"
#include "emadiag/sim/terms.hpp"

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace emadiag::sim {

/// Effects beyond the datasheet. All are off (zero) by default.
struct Effects {
    double viscous_nm_s_rad = 0.0;          ///< viscous friction F_v, motor side
    double stribeck_amplitude_nm = 0.0;     ///< extra friction at low speed, motor side
    double stribeck_speed_rad_s = 50.0;     ///< Stribeck characteristic speed, motor side
    double backlash_rad = 0.0;              ///< total free play, motor side
    double spall_amplitude_nm = 0.0;        ///< position-localised friction increase, motor side
    double spall_center_deg = 0.0;          ///< surface angle of the spall centre
    double spall_width_deg = 1.0;           ///< Gaussian half-width (1 sigma) of the spall, surface angle
    double ripple_amplitude_nm = 0.0;       ///< motor torque ripple amplitude
    double ripple_periods_per_rev = 6.0;    ///< ripple periods per motor revolution
    double current_gain_error = 0.0;        ///< measured I = (1 + error) * true I
    double hinge_offset_nm = 0.0;           ///< measured H = true H + offset (surface side)
    double true_inertia_kgm2 = 0.0;         ///< plant inertia; 0 means "as the datasheet J"

    [[nodiscard]] bool any() const;
    /// Names accepted by set() and reported as effect_<name> in CSV headers.
    static const std::vector<std::string>& names();
    /// Sets one effect by name; throws SimError naming the effect on an unknown name.
    void set(const std::string& name, double value);
    [[nodiscard]] double get(const std::string& name) const;

    /// The allowed range of one effect, [min, max] in its unit: the one definition, read by set()
    /// and by every fit of the effect (discovery narrows it only with a stated reason).
    struct Range {
        double min;
        double max;
        const char* unit;
    };
    /// Throws SimError naming the effect on an unknown name.
    [[nodiscard]] static Range range(const std::string& name);
};

/// Datasheet parameters (ema-reference.md section 1), SI units: the defaults are sim::ema_ref_1 (physics.hpp).
struct EmaParams {
    double v_dc_v = ema_ref_1::kVdcV;
    double r_ohm = ema_ref_1::kROhm;
    double l_h = ema_ref_1::kLH;
    double k_t_nm_per_a = ema_ref_1::kKtNmPerA;
    double i_max_a = ema_ref_1::kIMaxA;
    double t_max_nm = ema_ref_1::kTMaxNm;
    double w_max_rad_s = ema_ref_1::kWMaxRadS;
    double j_kgm2 = ema_ref_1::kJKgm2;
    double tau = ema_ref_1::kTau;
    double k_theta_per_s = ema_ref_1::kKThetaPerS;
    double k_w_a_s_per_rad = ema_ref_1::kKwASPerRad;
    double stop_deg = ema_ref_1::kStopDeg;
    double fdj_nm = ema_ref_1::kFdjNm;
    double fsj_nm = ema_ref_1::kFsjNm;
    double eta_o = ema_ref_1::kEtaO;
    double eta_a = ema_ref_1::kEtaA;  ///< overwritten from eta_o by eq. (4) unless set explicitly
    double dt_s = ema_ref_1::kDtS;
    Effects effects;
    /// Extra torque and sensor terms as data (terms.hpp); empty for the datasheet. JSON key "terms".
    std::vector<Term> terms;

    /// Throws SimError listing every invalid field with its value and allowed range.
    void validate() const;
    /// Plant inertia: effects.true_inertia_kgm2 when set, else the datasheet J.
    [[nodiscard]] double plant_inertia_kgm2() const;

    /// The datasheet, with eta_a from eq. (4).
    static EmaParams datasheet();
    /// Reads a JSON object; unknown keys and wrong types are errors. Missing keys keep the datasheet.
    static EmaParams from_json(const nlohmann::json& j, const std::string& where = "params");
    static EmaParams from_json_file(const std::string& path);
    [[nodiscard]] nlohmann::json to_json() const;
};

/// eq. (4): eta_A from eta_O and the gear ratio tau.
[[nodiscard]] double eta_a_from_eta_o(double eta_o, double tau);
/// Inverse of eq. (4): eta_O from eta_A and tau.
[[nodiscard]] double eta_o_from_eta_a(double eta_a, double tau);

}  // namespace emadiag::sim
