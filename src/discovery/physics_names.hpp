#pragma once
// Readable names of the common term forms (issue 10 part 1): a term the sparse selection keeps is
// reported with the physics it stands for, e.g. sgn(w)*abs(theta_u) is "friction growing with the
// deflection". Forms not in the table are reported literally as structure in their basis, never
// forced onto a name.
#include "emadiag/sim/terms.hpp"

#include <string>

namespace emadiag::discovery {

struct PhysicsName {
    std::string key;   ///< stable identifier ("friction_deflection"), or "structure" when not in the table
    std::string text;  ///< readable, with the term's parameters ("period 5 deg")
};

/// The table's name of one term (its target and the form of its factors; the coefficient is not read).
[[nodiscard]] PhysicsName physics_name(const sim::Term& term);

}  // namespace emadiag::discovery
