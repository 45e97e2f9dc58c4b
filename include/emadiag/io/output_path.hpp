#pragma once
// The one check every file emadiag writes goes through (issue 12 part 4; docs/limits.md): the path
// must name a regular file or nothing yet. A device (/dev/null, /dev/zero), a FIFO, a socket, a
// directory or a symbolic link is refused with the reason, never written through: a symlink could
// point anywhere (the maintenance database, a system file), and writing a run next to /dev/null
// then renaming it over the device would replace the device node. `..` is an ordinary path
// component of a path the user typed; names made from input data (tail numbers) are validated
// where they are made. Header-only: every library (can_dbc, maintenance_db, core) uses it.
#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <optional>
#include <string>

namespace emadiag::io {

/// Why `path` must not be written, or nullopt when it may (it does not exist yet, or it is a
/// regular file). `what` names the file in the message ("run CSV", "maintenance database").
[[nodiscard]] inline std::optional<std::string> output_path_problem(const std::string& path, const std::string& what) {
    if (path.empty()) return what + ": the output path is empty";
    if (path.find('\0') != std::string::npos) return what + ": the output path contains a NUL byte";
    struct stat st {};
    if (::lstat(path.c_str(), &st) != 0) {
        if (errno == ENOENT) return std::nullopt;
        return what + " " + path + ": cannot check the output path: " + std::strerror(errno);
    }
    const char* kind = nullptr;
    if (S_ISREG(st.st_mode)) return std::nullopt;
    if (S_ISLNK(st.st_mode)) kind = "a symbolic link (emadiag does not write through links; give the target's path)";
    else if (S_ISDIR(st.st_mode)) kind = "a directory";
    else if (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode)) kind = "a device file";
    else if (S_ISFIFO(st.st_mode)) kind = "a FIFO";
    else if (S_ISSOCK(st.st_mode)) kind = "a socket";
    else kind = "not a regular file";
    return what + " " + path + " is " + kind + "; refusing to write it";
}

}  // namespace emadiag::io
