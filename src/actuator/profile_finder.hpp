#pragma once
// Finds a profile for `--actuator FILE|PART_NUMBER` (issue 23 part 1): a path is read as given; a
// part number is looked up among the profiles (*.json, not *.map.json) of the first profile folder
// that exists, by the part number inside each file (not its file name). The folders come from the
// caller (the CLI: $EMADIAG_ACTUATORS_DIR, else <prefix>/share/emadiag/actuators from the binary's
// own location, else the build tree's source; never the current directory).
#include "actuator/actuator_profile.hpp"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace emadiag::actuator {

/// Most files a profile folder may hold (*.json): a folder beyond it is refused, never half read.
inline constexpr std::size_t kMaxProfilesInFolder = 1000;

/// A folder and how it was chosen ("installed", "build tree", "EMADIAG_ACTUATORS_DIR").
struct ProfileLocation {
    std::filesystem::path dir;
    std::string how;
};

/// One file of a folder: its profile, or why it is not one.
struct ListedProfile {
    std::filesystem::path file;
    std::optional<ActuatorProfile> profile;
    std::string error;  ///< the loader's message when profile is empty
};

/// True when `arg` names a file (it has a '/' or ends in ".json"), false for a part number.
[[nodiscard]] bool names_a_file(const std::string& arg);

/// The first location whose folder exists; nullopt when none does.
[[nodiscard]] std::optional<ProfileLocation> profile_folder(const std::vector<ProfileLocation>& locations);

/// Every profile file of `dir` (sorted by name), each loaded. Throws ActuatorError when the folder
/// cannot be listed or holds more than kMaxProfilesInFolder files.
[[nodiscard]] std::vector<ListedProfile> list_profiles(const std::filesystem::path& dir);

/// The profile `arg` names (a file, or a part number in the profile folder). Throws ActuatorError
/// naming the part number, the folder searched and the part numbers it holds when none matches, or
/// both files when two profiles carry the part number.
[[nodiscard]] ActuatorProfile find_profile(const std::string& arg, const std::vector<ProfileLocation>& locations);

}  // namespace emadiag::actuator
