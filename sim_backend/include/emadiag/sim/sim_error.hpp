#pragma once
#include <stdexcept>
#include <string>

namespace emadiag::sim {

/// The one exception type of sim_backend; every message starts with "[sim_backend] ".
class SimError : public std::runtime_error {
public:
    explicit SimError(const std::string& message) : std::runtime_error("[sim_backend] " + message) {}
};

}  // namespace emadiag::sim
