#include "discovery/physics_names.hpp"

#include <numbers>
#include <sstream>

namespace emadiag::discovery {
namespace {

using sim::TermBasis;
using sim::TermSignal;
using sim::TermTarget;

std::string num(double v) {
    std::ostringstream os;
    os.precision(3);
    os << v;
    return os.str();
}

bool is(const sim::TermFactor& f, TermBasis b, TermSignal s) { return f.basis == b && f.signal == s; }
bool periodic(const sim::TermFactor& f, TermSignal s) {
    return (f.basis == TermBasis::Sin || f.basis == TermBasis::Cos) && f.signal == s;
}

/// The form with the friction factor sgn(w) taken out (friction == true when it was there).
struct Form {
    bool friction = false;
    std::vector<sim::TermFactor> rest;
};

Form split(const sim::Term& t) {
    Form f;
    for (const auto& x : t.factors) {
        if (!f.friction && is(x, TermBasis::Sgn, TermSignal::Speed)) f.friction = true;
        else f.rest.push_back(x);
    }
    return f;
}

}  // namespace

PhysicsName physics_name(const sim::Term& t) {
    const Form f = split(t);
    const auto& r = f.rest;
    const std::size_t n = r.size();
    switch (t.target) {
        case TermTarget::Current:
            if (t.factors.empty()) return {"current_sensor_offset", "current sensor offset"};
            if (n == 1 && is(r[0], TermBasis::Identity, TermSignal::Current) && !f.friction)
                return {"current_sensor_gain", "current sensor gain error"};
            break;
        case TermTarget::Speed:
            if (t.factors.empty()) return {"speed_sensor_offset", "speed sensor offset"};
            if (n == 1 && is(r[0], TermBasis::Identity, TermSignal::Speed) && !f.friction)
                return {"speed_sensor_gain", "speed sensor gain error"};
            break;
        case TermTarget::Theta:
            if (t.factors.empty()) return {"theta_sensor_offset", "position sensor offset"};
            if (n == 1 && is(r[0], TermBasis::Identity, TermSignal::Time) && !f.friction)
                return {"theta_sensor_drift", "position sensor drift (offset growing with time)"};
            break;
        case TermTarget::Hinge:
            if (t.factors.empty()) return {"hinge_sensor_offset", "hinge-moment sensor offset"};
            if (n == 1 && is(r[0], TermBasis::Identity, TermSignal::LoadTorque) && !f.friction)
                return {"hinge_sensor_gain", "hinge-moment sensor gain error"};
            break;
        case TermTarget::Torque:
            if (t.factors.empty())
                return {"constant_torque", "constant torque on the shaft (Coulomb friction asymmetry, or a constant load)"};
            if (f.friction) {
                if (n == 1 && is(r[0], TermBasis::Abs, TermSignal::ThetaSurface))
                    return {"friction_deflection", "friction growing with the deflection (|surface angle|)"};
                if (n == 1 && is(r[0], TermBasis::Identity, TermSignal::ThetaSurface))
                    return {"friction_stroke", "friction changing along the stroke (surface angle)"};
                if (n == 1 && is(r[0], TermBasis::Square, TermSignal::LoadTorque))
                    return {"friction_load_squared", "friction growing with the square of the load (efficiency falling with load)"};
                if (n == 1 && is(r[0], TermBasis::Abs, TermSignal::LoadTorque))
                    return {"friction_load", "friction growing with the load (efficiency below the model)"};
                if (n == 1 && is(r[0], TermBasis::Identity, TermSignal::Time))
                    return {"friction_time", "friction changing during the run (warm-up or wear)"};
                if (n == 1 && is(r[0], TermBasis::Square, TermSignal::Speed))
                    return {"friction_speed_squared", "friction growing with the square of the speed"};
                if (n == 1 && periodic(r[0], TermSignal::ThetaSurface))
                    return {"periodic_friction_surface",
                            "friction periodic in the surface angle, period " + num(r[0].a) + " deg"};
                if (n == 1 && periodic(r[0], TermSignal::ThetaMotor))
                    return {"periodic_friction_motor", "friction periodic in the motor angle, period " + num(r[0].a) +
                                                           " rad (" + num(r[0].a / (2 * std::numbers::pi)) + " rev)"};
                if (n == 1 && r[0].basis == TermBasis::Gauss && r[0].signal == TermSignal::ThetaSurface)
                    return {"spall", "localised friction (spall) at surface angle " + num(r[0].a) + " deg"};
            } else {
                if (n == 1 && is(r[0], TermBasis::Identity, TermSignal::Speed)) return {"viscous", "viscous friction"};
                if (n == 2 && ((is(r[0], TermBasis::Identity, TermSignal::Speed) && is(r[1], TermBasis::Abs, TermSignal::LoadTorque)) ||
                               (is(r[1], TermBasis::Identity, TermSignal::Speed) && is(r[0], TermBasis::Abs, TermSignal::LoadTorque))))
                    return {"friction_speed_load", "friction growing with speed times load"};
                if (n == 1 && is(r[0], TermBasis::Identity, TermSignal::Current))
                    return {"motor_torque_constant", "motor torque constant off the datasheet (a real torque ~ I)"};
                if (n == 1 && is(r[0], TermBasis::Identity, TermSignal::LoadTorque))
                    return {"load_torque_gain", "load torque off the hinge reading (a real torque ~ F_R)"};
                if (n == 1 && is(r[0], TermBasis::Identity, TermSignal::Time))
                    return {"torque_time", "torque changing during the run"};
                if (n == 1 && periodic(r[0], TermSignal::ThetaSurface))
                    return {"periodic_torque_surface", "torque periodic in the surface angle, period " + num(r[0].a) + " deg"};
                if (n == 1 && periodic(r[0], TermSignal::ThetaMotor))
                    return {"periodic_torque_motor", "torque periodic in the motor angle, period " + num(r[0].a) + " rad (" +
                                                         num(r[0].a / (2 * std::numbers::pi)) + " rev)"};
                if (n == 1 && r[0].basis == TermBasis::Gauss && r[0].signal == TermSignal::ThetaSurface)
                    return {"localised_torque_surface", "localised torque (not friction) at surface angle " + num(r[0].a) +
                                                            " deg, width " + num(r[0].b) + " deg"};
            }
            break;
    }
    return {"structure", std::string(f.friction ? "friction-like " : "") + "structure ~ " + t.basis_text() + " on " +
                             sim::to_string(t.target) + " (no name in the table)"};
}

}  // namespace emadiag::discovery
