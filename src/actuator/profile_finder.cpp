#include "actuator/profile_finder.hpp"

#include "actuator/actuator_error.hpp"

#include <algorithm>

namespace emadiag::actuator {

namespace fs = std::filesystem;

bool names_a_file(const std::string& arg) {
    return arg.find('/') != std::string::npos || arg.ends_with(".json");
}

std::optional<ProfileLocation> profile_folder(const std::vector<ProfileLocation>& locations) {
    for (const ProfileLocation& l : locations) {
        std::error_code ec;
        if (fs::is_directory(l.dir, ec)) return l;
    }
    return std::nullopt;
}

std::vector<ListedProfile> list_profiles(const fs::path& dir) {
    std::vector<fs::path> files;
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (!name.ends_with(".json") || name.ends_with(".map.json")) continue;
        if (files.size() == kMaxProfilesInFolder) {
            throw ActuatorError(dir.string() + ": more than kMaxProfilesInFolder = " + std::to_string(kMaxProfilesInFolder) + " profile files");
        }
        files.push_back(it->path());
    }
    if (ec) throw ActuatorError(dir.string() + ": cannot list the profile folder: " + ec.message());
    std::sort(files.begin(), files.end());
    std::vector<ListedProfile> out;
    for (const fs::path& f : files) {
        ListedProfile l{f, std::nullopt, ""};
        try {
            l.profile = load_actuator_profile(f.string());
        } catch (const ActuatorError& e) {
            l.error = e.what();
        }
        out.push_back(std::move(l));
    }
    return out;
}

ActuatorProfile find_profile(const std::string& arg, const std::vector<ProfileLocation>& locations) {
    if (names_a_file(arg)) return load_actuator_profile(arg);
    const auto folder = profile_folder(locations);
    if (!folder) {
        std::string looked;
        for (const ProfileLocation& l : locations) looked += (looked.empty() ? "" : ", ") + l.dir.string() + " (" + l.how + ")";
        throw ActuatorError("no actuator profile folder to look up part number '" + arg + "' in (looked in: " +
                            (looked.empty() ? "nowhere: the binary's location is unknown" : looked) + "); give the profile's file instead");
    }
    std::vector<const ListedProfile*> matches;
    const std::vector<ListedProfile> listed = list_profiles(folder->dir);
    std::string known, broken;
    for (const ListedProfile& l : listed) {
        if (!l.profile) {
            broken += (broken.empty() ? "" : ", ") + l.file.filename().string();
            continue;
        }
        known += (known.empty() ? "" : ", ") + l.profile->part_number + " (" + l.file.filename().string() + ")";
        if (l.profile->part_number == arg) matches.push_back(&l);
    }
    if (matches.size() > 1) {
        throw ActuatorError("part number '" + arg + "' is in two profiles of " + folder->dir.string() + ": " + matches[0]->file.filename().string() +
                            " and " + matches[1]->file.filename().string());
    }
    if (matches.empty()) {
        throw ActuatorError("no actuator profile with part number '" + arg + "' in " + folder->dir.string() + " (" + folder->how +
                            "); it holds: " + (known.empty() ? "none" : known) + (broken.empty() ? "" : "; not valid profiles: " + broken) +
                            " (emadiag actuator check FILE says why)");
    }
    return *matches[0]->profile;
}

}  // namespace emadiag::actuator
