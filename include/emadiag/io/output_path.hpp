#pragma once
// The one way every file emadiag writes is written (issue 12 part 4, issue 21 item 4; docs/limits.md).
//
// The check (output_path_problem): the path must name a regular file or nothing yet, and none of the
// command's inputs or its database. A device (/dev/null, /dev/full), a FIFO, a socket, a directory or
// a symbolic link is refused with the reason, never written through or replaced: a symlink could
// point anywhere (the maintenance database, a system file), and renaming a file over /dev/full would
// replace the device node. An input is recognised by device and inode when both exist (a hard link, a
// second spelling of the path) and by its canonical path; a database also by its SQLite side files
// (-journal, -wal, -shm). `..` is an ordinary path component of a path the user typed.
//
// The write (OutputFile, write_output_file): the text goes to a new temporary file created with
// O_CREAT | O_EXCL (mkostemp: a planted file or symlink at any name is never opened) in the target's
// directory; it is fsynced, renamed over the target and the directory is fsynced. On any error (a full
// disk, an I/O error, an exception while the text is produced) the temporary is removed: the target
// keeps its old content or stays absent, and no partial file is left. The message names the path and
// the errno text.
//
// Fault hook for the tests (a full disk without root): EMADIAG_FAULT_OUTPUT_ENOSPC_AFTER_BYTES=N makes
// every output fail with ENOSPC after N bytes, as a full file system would.
//
// Header-only: every library (can_dbc, maintenance_db, core) uses it, each with its own exception
// type (OutputFile<CanError>).
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <optional>
#include <ostream>
#include <streambuf>
#include <string>
#include <utility>
#include <vector>

namespace emadiag::io {

/// The paths a command reads (its input files and its database): none may be an output.
struct OutputInputs {
    std::vector<std::string> files;      ///< input files (run CSV, dataset, model, limits...)
    std::vector<std::string> databases;  ///< SQLite databases: their -journal, -wal and -shm files are protected too

    OutputInputs() = default;
    OutputInputs(std::vector<std::string> files_, std::vector<std::string> databases_ = {})
        : files(std::move(files_)), databases(std::move(databases_)) {}
};

namespace detail {

inline std::string errno_text(int e) { return std::strerror(e); }

/// The canonical form of `path` (its existing prefix resolved), or the path itself when it cannot be made.
inline std::string canonical_or_self(const std::string& path) {
    std::error_code ec;
    const auto c = std::filesystem::weakly_canonical(std::filesystem::absolute(path, ec), ec);
    return ec ? path : c.string();
}

/// Is `out` (lstat'ed as `out_st`, or absent when out_exists is false) the same file as `input`?
inline bool same_file(const std::string& out, bool out_exists, const struct stat& out_st, const std::string& input) {
    if (input.empty()) return false;
    struct stat in_st {};
    if (out_exists && ::stat(input.c_str(), &in_st) == 0 && in_st.st_dev == out_st.st_dev && in_st.st_ino == out_st.st_ino) return true;
    return canonical_or_self(out) == canonical_or_self(input);
}

}  // namespace detail

/// Why `path` must not be written, or nullopt when it may (it does not exist yet, or it is a regular
/// file that is none of `inputs`). `what` names the file in the message ("run CSV", "report").
[[nodiscard]] inline std::optional<std::string> output_path_problem(const std::string& path, const std::string& what,
                                                                    const OutputInputs& inputs = {}) {
    if (path.empty()) return what + ": the output path is empty";
    if (path.find('\0') != std::string::npos) return what + ": the output path contains a NUL byte";
    struct stat st {};
    bool exists = true;
    if (::lstat(path.c_str(), &st) != 0) {
        if (errno != ENOENT) return what + " " + path + ": cannot check the output path: " + detail::errno_text(errno);
        exists = false;
    }
    if (exists && !S_ISREG(st.st_mode)) {
        const char* kind = nullptr;
        if (S_ISLNK(st.st_mode)) kind = "a symbolic link (emadiag does not write through links; give the target's path)";
        else if (S_ISDIR(st.st_mode)) kind = "a directory";
        else if (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode)) kind = "a device file";
        else if (S_ISFIFO(st.st_mode)) kind = "a FIFO";
        else if (S_ISSOCK(st.st_mode)) kind = "a socket";
        else kind = "not a regular file";
        return what + " " + path + " is " + kind + "; refusing to write it";
    }
    for (const auto& in : inputs.files)
        if (detail::same_file(path, exists, st, in))
            return what + " " + path + " is an input of this command (" + in + "); refusing to write over it";
    for (const auto& db : inputs.databases)
        for (const char* suffix : {"", "-journal", "-wal", "-shm"})
            if (detail::same_file(path, exists, st, db + suffix))
                return what + " " + path + " is " + (suffix[0] ? "a side file of " : "") + "the maintenance database (" + db +
                       "); refusing to write over it";
    return std::nullopt;
}

/// Throws Error(problem) when `path` must not be written (see output_path_problem). For the commands
/// that work for minutes before they write: refuse before the work, not after it.
template <class Error>
void check_output_path(const std::string& path, const std::string& what, const OutputInputs& inputs = {}) {
    if (auto problem = output_path_problem(path, what, inputs)) throw Error(*problem);
}

/// Several outputs of one command must differ from each other as well as from its inputs.
template <class Error>
void check_output_paths(const std::vector<std::pair<std::string, std::string>>& path_and_what, const OutputInputs& inputs = {}) {
    for (std::size_t i = 0; i < path_and_what.size(); ++i) {
        const auto& [path, what] = path_and_what[i];
        if (path.empty()) continue;
        check_output_path<Error>(path, what, inputs);
        for (std::size_t j = 0; j < i; ++j)
            if (!path_and_what[j].first.empty() && detail::canonical_or_self(path_and_what[j].first) == detail::canonical_or_self(path))
                throw Error(what + " " + path + " is also the " + path_and_what[j].second + " output; give two different files");
    }
}

/// A stream buffer writing to a file descriptor; remembers the first errno (the stream then fails).
class FdStreamBuf final : public std::streambuf {
public:
    explicit FdStreamBuf(int fd) : fd_(fd), budget_(fault_budget()) { setp(buffer_, buffer_ + sizeof buffer_); }
    [[nodiscard]] int error() const { return errno_; }
    /// Writes out what is buffered; false (error() set) on failure.
    bool drain() { return sync() == 0; }

protected:
    int_type overflow(int_type ch) override {
        if (sync() != 0) return traits_type::eof();
        if (!traits_type::eq_int_type(ch, traits_type::eof())) {
            *pptr() = traits_type::to_char_type(ch);
            pbump(1);
        }
        return traits_type::not_eof(ch);
    }
    int sync() override {
        const char* p = pbase();
        const std::size_t n = static_cast<std::size_t>(pptr() - pbase());
        if (errno_ != 0) return -1;
        if (!write_all(p, n)) return -1;
        setp(buffer_, buffer_ + sizeof buffer_);
        return 0;
    }

private:
    /// EMADIAG_FAULT_OUTPUT_ENOSPC_AFTER_BYTES (see the top of this file), or -1 (no fault).
    static long long fault_budget() {
        const char* v = std::getenv("EMADIAG_FAULT_OUTPUT_ENOSPC_AFTER_BYTES");
        if (v == nullptr || *v == '\0') return -1;
        char* end = nullptr;
        const long long n = std::strtoll(v, &end, 10);
        return (end && *end == '\0' && n >= 0) ? n : -1;
    }
    bool write_all(const char* p, std::size_t n) {
        while (n > 0) {
            std::size_t chunk = n;
            if (budget_ >= 0) {
                if (budget_ == 0) {
                    errno_ = ENOSPC;
                    return false;
                }
                chunk = std::min<std::size_t>(chunk, static_cast<std::size_t>(budget_));
            }
            const ssize_t w = ::write(fd_, p, chunk);
            if (w < 0 && errno == EINTR) continue;
            if (w <= 0) {
                errno_ = w < 0 ? errno : EIO;
                return false;
            }
            if (budget_ >= 0) budget_ -= w;
            p += w;
            n -= static_cast<std::size_t>(w);
        }
        return true;
    }
    int fd_;
    long long budget_;
    int errno_ = 0;
    char buffer_[1 << 16];
};

/// One output file written whole or not at all (see the top of this file). Write to stream(), then
/// commit(); destroyed without commit (an exception, an early return), it removes its temporary.
template <class Error>
class OutputFile {
public:
    OutputFile(std::string path, std::string what, const OutputInputs& inputs = {}) : path_(std::move(path)), what_(std::move(what)) {
        check_output_path<Error>(path_, what_, inputs);
        const std::filesystem::path target(path_);
        const std::filesystem::path dir = target.has_parent_path() ? target.parent_path() : std::filesystem::path(".");
        std::string leaf(".");  // ".NAME.XXXXXX" (appended, not "." + name: GCC 12 warns a false -Wrestrict on that)
        leaf.append(target.filename().string()).append(".XXXXXX");
        std::string name = (dir / leaf).string();
        fd_ = ::mkostemp(name.data(), O_CLOEXEC);  // O_CREAT | O_EXCL, mode 0600: never an existing file or link
        if (fd_ < 0) fail("cannot create a temporary file in " + dir.string(), errno);
        tmp_ = name;
        // The mode a new file would get (0666 less the umask), or the mode of the file it replaces.
        struct stat st {};
        mode_t mode = 0;
        if (::stat(path_.c_str(), &st) == 0) {
            mode = st.st_mode & 07777;
        } else {
            const mode_t mask = ::umask(0);
            ::umask(mask);
            mode = 0666 & ~mask;
        }
        (void)::fchmod(fd_, mode);
        buf_.emplace(fd_);
        stream_.rdbuf(&*buf_);
    }
    ~OutputFile() { discard(); }
    OutputFile(const OutputFile&) = delete;
    OutputFile& operator=(const OutputFile&) = delete;

    [[nodiscard]] std::ostream& stream() { return stream_; }
    [[nodiscard]] const std::string& path() const { return path_; }

    /// Flushes, fsyncs, renames the temporary over the target and fsyncs the directory. Throws
    /// Error naming the path and the errno text; the temporary is then gone.
    void commit() {
        if (fd_ < 0) throw Error(what_ + " " + path_ + ": already written or discarded");
        stream_.flush();
        if (!buf_->drain() || !stream_) fail("cannot write", buf_->error() != 0 ? buf_->error() : EIO);
        if (::fsync(fd_) != 0) fail("cannot write (fsync)", errno);
        const int fd = fd_;
        fd_ = -1;
        if (::close(fd) != 0) fail("cannot write (close)", errno);
        // Checked again just before the rename: the path may have been replaced while the text was made.
        if (auto problem = output_path_problem(path_, what_)) {
            remove_tmp();
            throw Error(*problem);
        }
        if (::rename(tmp_.c_str(), path_.c_str()) != 0) fail("cannot move the output into place", errno);
        tmp_.clear();
        const std::filesystem::path target(path_);
        const std::string dir = target.has_parent_path() ? target.parent_path().string() : std::string(".");
        const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        if (dfd >= 0) {
            (void)::fsync(dfd);
            ::close(dfd);
        }
    }

private:
    [[noreturn]] void fail(const std::string& doing, int e) {
        discard();
        throw Error(what_ + " " + path_ + ": " + doing + ": " + detail::errno_text(e) + "; nothing was written");
    }
    void remove_tmp() noexcept {
        if (!tmp_.empty()) ::unlink(tmp_.c_str());
        tmp_.clear();
    }
    void discard() noexcept {
        if (fd_ >= 0) ::close(fd_);
        fd_ = -1;
        remove_tmp();
    }
    std::string path_, what_, tmp_;
    int fd_ = -1;
    std::optional<FdStreamBuf> buf_;
    std::ostream stream_{nullptr};
};

/// Writes the file `path` whole or not at all with what `produce` puts in the stream (an exception
/// from `produce` leaves no file).
template <class Error>
void write_output_file(const std::string& path, const std::string& what, const OutputInputs& inputs,
                       const std::function<void(std::ostream&)>& produce) {
    OutputFile<Error> out(path, what, inputs);
    produce(out.stream());
    out.commit();
}

/// Writes `text` to the file `path` whole or not at all.
template <class Error>
void write_output_file(const std::string& path, const std::string& what, const OutputInputs& inputs, const std::string& text) {
    OutputFile<Error> out(path, what, inputs);
    out.stream().write(text.data(), static_cast<std::streamsize>(text.size()));
    out.commit();
}

}  // namespace emadiag::io
