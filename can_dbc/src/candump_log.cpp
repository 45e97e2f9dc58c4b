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
#include <cstdint>
#include <istream>
#include <optional>

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
/// The raw DLCs above 8 that candump -8 writes after an 8-byte frame ("_9".."_F").
constexpr int kMinRawDlc = 9;

/// Reads "_X" at line[i] (X a raw DLC 9..F, then the end or a space); advances i past it.
bool parse_raw_dlc(std::string_view line, std::size_t& i, std::uint8_t& raw_dlc) {
    if (i + 1 >= line.size() || line[i] != '_' || hex_value(line[i + 1]) < kMinRawDlc) return false;
    if (i + 2 < line.size() && !std::isspace(static_cast<unsigned char>(line[i + 2]))) return false;
    raw_dlc = static_cast<std::uint8_t>(hex_value(line[i + 1]));
    i += 2;
    return true;
}

bool is_blank(std::string_view line) {
    for (char c : line)
        if (!std::isspace(static_cast<unsigned char>(c))) return false;
    return true;
}

std::vector<std::string_view> tokens(std::string_view line) {
    std::vector<std::string_view> out;
    std::size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
        const std::size_t start = i;
        while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
        if (i > start) out.push_back(line.substr(start, i - start));
    }
    return out;
}

bool all_hex(std::string_view s) {
    if (s.empty()) return false;
    for (char c : s)
        if (hex_value(c) < 0) return false;
    return true;
}

/// Plain `candump can0` console output: "  can0  123   [8]  11 22 ..." (with -t, a "(time)" first).
bool looks_like_console_output(std::string_view line) {
    auto t = tokens(line);
    if (!t.empty() && t[0].front() == '(' && t[0].back() == ')') t.erase(t.begin());
    return t.size() >= 3 && all_hex(t[1]) && t[2].size() >= 3 && t[2].front() == '[' && t[2].back() == ']';
}

/// A CAN XL line of candump -l: "(time) iface PPP#FF:SS:AAAAAAAA#data" (priority id, then flags,
/// SDT and acceptance field separated by ':').
bool is_can_xl_line(std::string_view line) {
    const auto t = tokens(line);
    if (t.size() < 3 || t[0].front() != '(') return false;
    const std::string_view frame = t[2];
    const std::size_t hash = frame.find('#');
    return hash != std::string_view::npos && hash + 3 < frame.size() && hex_value(frame[hash + 1]) >= 0 &&
           hex_value(frame[hash + 2]) >= 0 && frame[hash + 3] == ':';
}

/// candump's "DROPCOUNT: dropped N CAN frame(s) on 'can0' socket (total drops M)"; returns N.
std::optional<std::uint64_t> dropcount(std::string_view line) {
    const auto t = tokens(line);
    if (t.empty() || t[0] != "DROPCOUNT:") return std::nullopt;
    std::uint64_t n = 0;
    if (t.size() >= 3 && t[1] == "dropped") {
        for (char c : t[2]) {
            if (!std::isdigit(static_cast<unsigned char>(c)) || n > (UINT64_MAX - 9) / 10) return std::uint64_t{0};
            n = n * 10 + static_cast<std::uint64_t>(c - '0');
        }
    }
    return n;
}

/// `s` cut to `max` bytes with every byte outside printable ASCII shown as '?' (a note quotes a line).
std::string printable(std::string_view s, std::size_t max) {
    std::string out(s.substr(0, max));
    for (char& c : out)
        if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7F) c = '?';
    return out;
}

std::string plural(std::size_t n, const std::string& word) { return std::to_string(n) + " " + word + (n == 1 ? "" : "s"); }

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
            // Bits 30 and 31 are CAN_RTR_FLAG and CAN_EFF_FLAG, never set in an error frame's id:
            // the error class is the 29 bits below CAN_ERR_FLAG (fuzz_candump finding, issue 21 item 17).
            if (id > (kCanErrFlag | kExtendedIdMask))
                return fail(id_start, "error frame id " + std::string(line.substr(id_start, id_digits)) +
                                          " has bits above CAN_ERR_FLAG 20000000 and the 29-bit error class");
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
            if (f.len == kClassicMaxLen && i < line.size() && line[i] == '_') {
                if (!parse_raw_dlc(line, i, r.raw_dlc)) return fail(i, "expected a raw DLC 9..F after '_'");
            }
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
        if (line[i] == '_') {  // candump -8: the raw DLC of an 8-byte classic frame
            if (f.fd || n != kClassicMaxLen) return fail(i, "a raw DLC suffix '_' follows exactly 8 data bytes of a classic frame");
            if (!parse_raw_dlc(line, i, r.raw_dlc)) return fail(i, "expected a raw DLC 9..F after '_'");
            break;
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

std::string CandumpReport::summary() const {
    std::string s = plural(frames, "frame");
    if (fd_frames > 0 || remote_frames > 0) {
        s += " (";
        if (fd_frames > 0) s += std::to_string(fd_frames) + " CAN FD";
        if (fd_frames > 0 && remote_frames > 0) s += ", ";
        if (remote_frames > 0) s += std::to_string(remote_frames) + " remote";
        s += ")";
    }
    if (error_frames > 0) s += ", " + plural(error_frames, "error frame");
    std::vector<std::string> skipped;
    if (skipped_lines > 0) skipped.push_back(plural(skipped_lines, "torn or malformed line"));
    if (can_xl_lines > 0) skipped.push_back(plural(can_xl_lines, "CAN XL line"));
    if (dropcount_lines > 0) skipped.push_back(plural(dropcount_lines, "DROPCOUNT notice") + " (candump lost " +
                                               plural(static_cast<std::size_t>(frames_dropped_by_candump), "frame") + ")");
    if (!skipped.empty()) {
        s += "; skipped ";
        for (std::size_t i = 0; i < skipped.size(); ++i) s += (i > 0 ? ", " : "") + skipped[i];
    }
    if (raw_dlc_suffixes > 0) s += "; ignored " + std::to_string(raw_dlc_suffixes) + " raw DLC suffix" + (raw_dlc_suffixes == 1 ? "" : "es") + " (\"_E\")";
    if (time_steps_back > 0) s += "; time went back " + plural(time_steps_back, "time");
    return s;
}

CandumpReport for_each_candump_record(std::istream& in, const std::string& name, const std::function<void(CandumpRecord&&)>& on_record,
                                      CandumpMode mode) {
    CandumpReport rep;
    std::vector<std::string> errors;  // strict mode: the bad lines
    std::size_t bad_lines = 0;
    std::string line;
    std::size_t lineno = 0;
    bool too_long = false;
    bool first_content = true;
    std::optional<std::chrono::nanoseconds> last_time;
    auto note = [&](std::string text) {
        if (rep.messages.size() < kCandumpMaxReportedErrors) rep.messages.push_back(std::move(text));
        else ++rep.messages_left_out;
    };
    auto where = [&](const std::string& col) { return name + ":" + std::to_string(lineno) + ":" + col; };
    auto bad = [&](const std::string& text) {  // text: "col: message"
        ++bad_lines;
        rep.last_line_torn = in.eof();  // no final newline after this line: so far the last one
        if (mode == CandumpMode::Strict) {
            if (errors.size() < kCandumpMaxReportedErrors) errors.push_back(where(text));
        } else {
            ++rep.skipped_lines;
            note(where(text) + "; line skipped");
        }
    };
    while (io::read_bounded_line(in, line, kCandumpMaxLineBytes, too_long)) {
        ++lineno;
        ++rep.lines;
        rep.last_line_torn = false;
        if (too_long) {
            bad("1: line longer than the limit kCandumpMaxLineBytes = " + std::to_string(kCandumpMaxLineBytes) + " bytes");
            continue;
        }
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (is_blank(line)) continue;
        if (first_content && looks_like_console_output(line)) {
            throw CanError(where("1") + ": this is the console output of plain `candump can0` (\"IFACE ID [LEN] BYTES\"), not a " +
                           "candump log: it has no receive timestamps; record the bus with `candump -l` (or `emadiag record`)");
        }
        first_content = false;
        if (const auto dropped = dropcount(line)) {
            ++rep.dropcount_lines;
            rep.frames_dropped_by_candump += *dropped;
            note(where("1") + ": candump's own notice \"" + printable(line, 120) + "\": the recording lost " +
                 plural(static_cast<std::size_t>(*dropped), "frame") + " here; line skipped");
            continue;
        }
        if (is_can_xl_line(line)) {
            ++rep.can_xl_lines;
            note(where("1") + ": CAN XL frame, not supported (CAN and CAN FD only); line skipped");
            continue;
        }
        std::string err;
        auto r = parse_candump_line(line, err);
        if (!r) {
            bad(err);
            continue;
        }
        if (r->frame.error) ++rep.error_frames;
        else {
            ++rep.frames;
            if (r->frame.fd) ++rep.fd_frames;
            if (r->frame.rtr) ++rep.remote_frames;
        }
        if (r->raw_dlc != 0) {
            if (rep.raw_dlc_suffixes++ == 0)
                note(where("1") + ": raw DLC suffix \"_" + std::string(1, "0123456789ABCDEF"[r->raw_dlc]) +
                     "\" (candump -8) ignored; the 8 data bytes are kept (and on every such line after this one)");
        }
        if (last_time && r->frame.timestamp < *last_time && rep.time_steps_back++ == 0)
            note(where("1") + ": timestamp earlier than the line before; frames kept in file order (and on every such line after this one)");
        last_time = r->frame.timestamp;
        on_record(std::move(*r));
    }
    if (in.bad()) throw CanError(name + ": read error after line " + std::to_string(lineno));
    if (rep.last_line_torn && mode == CandumpMode::Lenient)
        note(name + ":" + std::to_string(lineno) + ": the last line is incomplete and has no final newline: the recording was cut short");
    const bool nothing_good = bad_lines > 0 && rep.frames == 0 && rep.error_frames == 0;
    if (bad_lines > 0 && (mode == CandumpMode::Strict || nothing_good)) {
        std::vector<std::string> listed = errors;
        if (mode == CandumpMode::Lenient)
            for (const auto& m : rep.messages) listed.push_back(m);
        std::string all = plural(bad_lines, "bad line") + " in candump log " + name +
                          (mode == CandumpMode::Lenient ? " and no good frame" : "") +
                          (bad_lines > listed.size() ? " (the first " + std::to_string(listed.size()) + " listed)" : "") + ":";
        for (const auto& e : listed) all += "\n" + e;
        throw CanError(all);
    }
    return rep;
}

std::vector<CandumpRecord> read_candump(std::istream& in, const std::string& name, CandumpMode mode, CandumpReport* report) {
    std::vector<CandumpRecord> out;
    CandumpReport rep = for_each_candump_record(
        in, name,
        [&](CandumpRecord&& r) {
            if (out.size() >= kCandumpMaxRecords) {
                throw CanError(name + ": more than the limit kCandumpMaxRecords = " + std::to_string(kCandumpMaxRecords) +
                               " frames for a log held in memory (replay); split the log");
            }
            out.push_back(std::move(r));
        },
        mode);
    if (report) *report = std::move(rep);
    return out;
}

std::vector<CandumpRecord> read_candump_file(const std::string& path, CandumpMode mode, CandumpReport* report) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw CanError(path + ": cannot open the candump log");
    return read_candump(in, path, mode, report);
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
