#include "emadiag/can/candump_log.hpp"
#include "emadiag/io/bounded_line.hpp"

#include "emadiag/can/can_error.hpp"
#include "emadiag/io/output_path.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <cctype>
#include <cstdio>
#include <istream>

namespace emadiag::can {
namespace {

int hex_value(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    return -1;
}

constexpr char kHex[] = "0123456789ABCDEF";
constexpr std::uint8_t kFdFlagBrs = 0x1;
constexpr std::uint8_t kFdFlagEsi = 0x2;
constexpr std::size_t kStandardIdDigits = 3;
constexpr std::size_t kExtendedIdDigits = 8;

}  // namespace

std::string format_candump_line(const CanFrame& f, const std::string& iface) {
    const auto ns = f.timestamp.count();
    const long long sec = ns / 1000000000LL;
    const long long usec = (ns % 1000000000LL) / 1000LL;
    char head[64];
    std::snprintf(head, sizeof head, "(%010lld.%06lld) ", sec, usec);
    std::string s = head;
    s += iface;
    s += ' ';
    char idbuf[16];
    if (f.error) std::snprintf(idbuf, sizeof idbuf, "%08X", (f.id & kExtendedIdMask) | kCanErrFlag);
    else if (f.extended) std::snprintf(idbuf, sizeof idbuf, "%08X", f.id & kExtendedIdMask);
    else std::snprintf(idbuf, sizeof idbuf, "%03X", f.id & kStandardIdMask);
    s += idbuf;
    s += '#';
    if (f.fd) {
        s += '#';
        s += kHex[(f.brs ? kFdFlagBrs : 0) | (f.esi ? kFdFlagEsi : 0)];
    } else if (f.rtr) {
        s += 'R';
        if (f.len > 0) s += static_cast<char>('0' + f.len);  // the requested length, as candump writes it
        return s;
    }
    for (std::size_t i = 0; i < f.len; ++i) {
        s += kHex[f.data[i] >> 4];
        s += kHex[f.data[i] & 0xF];
    }
    return s;
}

std::optional<CandumpRecord> parse_candump_line(std::string_view line, std::string& error) {
    auto fail = [&](std::size_t col, const std::string& msg) -> std::optional<CandumpRecord> {
        error = std::to_string(col + 1) + ": " + msg;
        return std::nullopt;
    };
    std::size_t i = 0;
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i >= line.size() || line[i] != '(') return fail(i, "expected '(' and a timestamp (sec.usec)");
    ++i;
    long long sec = 0, usec = 0;
    std::size_t digits = 0;
    // Seconds since 1970 up to 9e9 (the year 2255): sec * 1e9 + ns must fit the int64 nanoseconds.
    constexpr long long kMaxSeconds = 9'000'000'000LL;
    while (i < line.size() && std::isdigit(static_cast<unsigned char>(line[i]))) {
        sec = sec * 10 + (line[i++] - '0');
        if (sec > kMaxSeconds) return fail(i - 1, "timestamp seconds beyond 9000000000 (the year 2255)");
        ++digits;
    }
    if (digits == 0 || i >= line.size() || line[i] != '.') return fail(i, "expected the timestamp as sec.usec");
    ++i;
    digits = 0;
    long long frac_scale = 1000000000LL;
    long long frac_ns = 0;
    while (i < line.size() && std::isdigit(static_cast<unsigned char>(line[i]))) {
        if (digits < 9) {
            frac_scale /= 10;
            frac_ns += (line[i] - '0') * frac_scale;
        }
        ++i;
        ++digits;
    }
    (void)usec;
    if (digits == 0 || i >= line.size() || line[i] != ')') return fail(i, "expected digits and ')' after the timestamp");
    ++i;
    while (i < line.size() && line[i] == ' ') ++i;
    const std::size_t iface_start = i;
    while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i == iface_start) return fail(i, "expected the interface name");
    CandumpRecord r;
    r.iface = std::string(line.substr(iface_start, i - iface_start));
    while (i < line.size() && line[i] == ' ') ++i;
    const std::size_t id_start = i;
    std::uint32_t id = 0;
    while (i < line.size() && hex_value(line[i]) >= 0) id = (id << 4) | static_cast<std::uint32_t>(hex_value(line[i++]));
    const std::size_t id_digits = i - id_start;
    if (i >= line.size() || line[i] != '#') return fail(i, "expected hex id digits and '#'");
    CanFrame& f = r.frame;
    if (id_digits == kStandardIdDigits) {
        if (id > kStandardIdMask) return fail(id_start, "11-bit id " + std::string(line.substr(id_start, id_digits)) + " above 7FF");
        f.id = id;
    } else if (id_digits == kExtendedIdDigits) {
        if (id & kCanErrFlag) {
            f.error = true;
            f.id = id & ~kCanErrFlag;
        } else if (id > kExtendedIdMask) {
            return fail(id_start, "29-bit id " + std::string(line.substr(id_start, id_digits)) + " above 1FFFFFFF");
        } else {
            f.id = id;
            f.extended = true;
        }
    } else {
        return fail(id_start, "id must have 3 (standard) or 8 (extended) hex digits, found " + std::to_string(id_digits));
    }
    ++i;
    std::size_t max_len = kClassicMaxLen;
    if (i < line.size() && line[i] == '#') {
        ++i;
        if (i >= line.size() || hex_value(line[i]) < 0) return fail(i, "expected the CAN FD flags nibble after '##'");
        const int flags = hex_value(line[i++]);
        f.fd = true;
        f.brs = (flags & kFdFlagBrs) != 0;
        f.esi = (flags & kFdFlagEsi) != 0;
        max_len = kFdMaxLen;
    } else if (i < line.size() && (line[i] == 'R' || line[i] == 'r')) {
        f.rtr = true;
        ++i;
        if (i < line.size() && std::isdigit(static_cast<unsigned char>(line[i]))) {
            if (line[i] > '8') return fail(i, "remote request length above 8");
            f.len = static_cast<std::uint8_t>(line[i++] - '0');
        }
        if (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i])))
            return fail(i, "unexpected text after the remote request");
    }
    std::size_t n = 0;
    while (!f.rtr && i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) {
        if (line[i] == '.') {  // optional byte separator
            ++i;
            continue;
        }
        if (i + 1 >= line.size() || hex_value(line[i]) < 0 || hex_value(line[i + 1]) < 0)
            return fail(i, "expected data as pairs of hex digits");
        if (n >= max_len) return fail(i, std::string("more than ") + std::to_string(max_len) + " data bytes");
        f.data[n++] = static_cast<std::uint8_t>(hex_value(line[i]) << 4 | hex_value(line[i + 1]));
        i += 2;
    }
    if (!f.rtr) f.len = static_cast<std::uint8_t>(n);
    if (f.fd && !is_valid_fd_len(n)) return fail(i, std::to_string(n) + " bytes is not a CAN FD length");
    // Trailing fields (newer candump writes a direction flag " R"/" T") are ignored.
    f.timestamp = std::chrono::nanoseconds(sec * 1000000000LL + frac_ns);
    return r;
}

void for_each_candump_record(std::istream& in, const std::string& name, const std::function<void(CandumpRecord&&)>& on_record) {
    std::vector<std::string> errors;
    std::size_t bad_lines = 0;
    std::string line;
    std::size_t lineno = 0;
    bool too_long = false;
    auto bad = [&](std::string text) {
        if (++bad_lines <= kCandumpMaxReportedErrors) errors.push_back(name + ":" + std::to_string(lineno) + ":" + text);
    };
    while (io::read_bounded_line(in, line, kCandumpMaxLineBytes, too_long)) {
        ++lineno;
        if (too_long) {
            bad("1: line longer than the limit kCandumpMaxLineBytes = " + std::to_string(kCandumpMaxLineBytes) + " bytes");
            continue;
        }
        if (!line.empty() && line.back() == '\r') line.pop_back();
        bool blank = true;
        for (char c : line) blank = blank && std::isspace(static_cast<unsigned char>(c));
        if (blank) continue;
        std::string err;
        auto r = parse_candump_line(line, err);
        if (r) on_record(std::move(*r));
        else bad(err);
    }
    if (in.bad()) throw CanError(name + ": read error after line " + std::to_string(lineno));
    if (bad_lines > 0) {
        std::string all = std::to_string(bad_lines) + " bad line" + (bad_lines == 1 ? "" : "s") + " in candump log " + name +
                          (bad_lines > errors.size() ? " (the first " + std::to_string(errors.size()) + " listed)" : "") + ":";
        for (const auto& e : errors) all += "\n" + e;
        throw CanError(all);
    }
}

std::vector<CandumpRecord> read_candump(std::istream& in, const std::string& name) {
    std::vector<CandumpRecord> out;
    for_each_candump_record(in, name, [&](CandumpRecord&& r) {
        if (out.size() >= kCandumpMaxRecords) {
            throw CanError(name + ": more than the limit kCandumpMaxRecords = " + std::to_string(kCandumpMaxRecords) +
                           " frames for a log held in memory (replay); split the log");
        }
        out.push_back(std::move(r));
    });
    return out;
}

std::vector<CandumpRecord> read_candump_file(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw CanError(path + ": cannot open the candump log");
    return read_candump(in, path);
}

CandumpWriter::CandumpWriter(const std::string& path, CandumpWriterBounds bounds)
    : path_(path), bounds_(bounds), last_flush_(std::chrono::steady_clock::now()) {
    io::check_output_path<CanError>(path, "candump log");
    fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC, 0666);
    if (fd_ < 0) throw CanError(path + ": cannot create the candump log: " + std::strerror(errno));
    struct stat st {};
    if (::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) {  // replaced by a device or FIFO since the check
        ::close(fd_);
        fd_ = -1;
        throw CanError(path + ": the candump log is not a regular file; refusing to write it");
    }
    buffer_.reserve(bounds_.max_buffered_bytes + 128);
}

CandumpWriter::~CandumpWriter() {
    // Every exit path keeps the log: unwinding after an error included. A destructor never throws.
    try {
        flush();
    } catch (...) {
    }
    if (fd_ >= 0) ::close(fd_);
}

void CandumpWriter::write(const CanFrame& frame, const std::string& iface) {
    buffer_ += format_candump_line(frame, iface);
    buffer_ += '\n';
    ++lines_;
    // The clock is read once per kTimeCheckLines lines: on some hosts (user-mode Linux) every clock
    // reading is a system call.
    constexpr std::size_t kTimeCheckLines = 32;
    if (buffer_.size() >= bounds_.max_buffered_bytes ||
        (lines_ % kTimeCheckLines == 0 && std::chrono::steady_clock::now() - last_flush_ >= bounds_.max_buffered_time))
        flush();
}

void CandumpWriter::flush() {
    last_flush_ = std::chrono::steady_clock::now();
    std::size_t done = 0;
    while (done < buffer_.size()) {
        const ssize_t n = ::write(fd_, buffer_.data() + done, buffer_.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            const int e = n < 0 ? errno : EIO;
            buffer_.erase(0, done);
            throw CanError(path_ + ": write failed: " + std::strerror(e) + " (" + std::to_string(lines_) + " lines logged so far)");
        }
        done += static_cast<std::size_t>(n);
    }
    buffer_.clear();
}

}  // namespace emadiag::can
