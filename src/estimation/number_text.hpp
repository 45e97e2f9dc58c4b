#pragma once
// A number as the estimation library's messages quote it: 10 significant digits, so a value a file
// holds is recognisable in the error that names it (run checks, model checks).
#include <sstream>
#include <string>

namespace emadiag {

[[nodiscard]] inline std::string number_text(double v) {
    std::ostringstream os;
    os.precision(10);
    os << v;
    return os.str();
}

}  // namespace emadiag
