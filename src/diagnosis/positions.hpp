#pragma once
// The positions an EMA can be installed at on an aircraft, each with its ATA chapter 27 (flight
// controls) reference. A default list is built in (docs/fleet-record.md); an operator replaces it
// with a JSON file (--positions FILE, or the EMADIAG_POSITIONS environment variable):
//   {"positions": [{"name": "LH-ELEV", "ata": "27-30", "description": "left elevator"}, ...]}
// An unknown position is an error that lists the known ones, raised before anything moves.
#include <optional>
#include <string>
#include <vector>

namespace emadiag {

struct Position {
    std::string name;         ///< e.g. "LH-ELEV": 1 to 16 of A-Z, 0-9, '-'
    std::string ata;          ///< ATA chapter 27 reference, e.g. "27-30" (elevator)
    std::string description;
};

/// Bounds of a positions file (issue 21 item 13): it must be a regular file of at most
/// kMaxPositionsFileBytes (read in bounded chunks), with at most kMaxPositions positions whose
/// descriptions are printable and at most kMaxPositionDescriptionChars long.
inline constexpr std::size_t kMaxPositionsFileBytes = 64 * 1024;
inline constexpr std::size_t kMaxPositions = 256;
inline constexpr std::size_t kMaxPositionDescriptionChars = 120;

/// The environment variable naming a positions file when --positions is not given.
inline constexpr const char* kPositionsEnv = "EMADIAG_POSITIONS";

struct PositionList {
    std::vector<Position> positions;
    std::string source;  ///< "built-in" or the file
    std::string sha256;  ///< of the file's bytes, or of the built-in list's JSON

    /// The built-in list: ailerons, elevators, rudder, spoilers, flaps of a small transport aircraft.
    [[nodiscard]] static PositionList defaults();
    /// Reads a positions file; EmadiagError lists every problem as "file: position N: ...".
    [[nodiscard]] static PositionList load(const std::string& path);
    /// `path` if not empty, else $EMADIAG_POSITIONS if set, else the defaults.
    [[nodiscard]] static PositionList resolve(const std::string& path);

    /// The position of that name; EmadiagError "unknown position 'X' (known positions: ...; see
    /// docs/fleet-record.md to configure them)" otherwise.
    [[nodiscard]] const Position& find(const std::string& name) const;
    [[nodiscard]] std::string names() const;
};

}  // namespace emadiag
