#pragma once
#include <stdexcept>
#include <string>

namespace emadiag {

/// The one exception type of the diagnosis core and the CLI; messages start with "[emadiag] ".
class EmadiagError : public std::runtime_error {
public:
    explicit EmadiagError(const std::string& message) : std::runtime_error("[emadiag] " + message) {}
};

}  // namespace emadiag
