#pragma once
#include <stdexcept>
#include <string>

namespace emadiag::can {

/// The one exception type of can_dbc; every message starts with "[can_dbc] ".
class CanError : public std::runtime_error {
public:
    explicit CanError(const std::string& message) : std::runtime_error("[can_dbc] " + message) {}
};

}  // namespace emadiag::can
