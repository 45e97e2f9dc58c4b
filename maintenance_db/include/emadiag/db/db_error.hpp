#pragma once
#include <stdexcept>
#include <string>

namespace emadiag::db {

/// What went wrong, for a caller that acts on it (e.g. spools a session it could not store when the
/// database is locked or the disk is full).
enum class DbErrorKind {
    Invalid,   ///< bad input or misuse; nothing was written
    Busy,      ///< locked by another writer beyond the busy timeout; nothing was written
    Full,      ///< the disk (or the database's size limit) is full; nothing was written
    Corrupt,   ///< the file is not a sound SQLite database; it is never written to
    ReadOnly,  ///< the file or its directory cannot be written
    /// a tail's hash chain (or its anchor) shows a change made outside the tool: nothing is appended
    /// to it (emadiag verify names every problem)
    BrokenChain,
    Other,
};

/// The one exception type of maintenance_db; messages start with "[maintenance_db] ".
class DbError : public std::runtime_error {
public:
    explicit DbError(const std::string& message, DbErrorKind kind = DbErrorKind::Other)
        : std::runtime_error("[maintenance_db] " + message), kind_(kind) {}
    [[nodiscard]] DbErrorKind kind() const { return kind_; }

private:
    DbErrorKind kind_;
};

}  // namespace emadiag::db
