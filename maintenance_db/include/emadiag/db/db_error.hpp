#pragma once
#include <stdexcept>
#include <string>

namespace emadiag::db {

/// The one exception type of maintenance_db; messages start with "[maintenance_db] ".
class DbError : public std::runtime_error {
public:
    explicit DbError(const std::string& message) : std::runtime_error("[maintenance_db] " + message) {}
};

}  // namespace emadiag::db
