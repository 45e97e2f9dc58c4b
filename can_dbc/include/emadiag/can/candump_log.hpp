#pragma once
// candump log files, as written by `candump -l` and read by `canplayer`:
//   (1700000000.123456) vcan0 123#DEADBEEF        classic frame (3 hex digits: 11-bit id)
//   (1700000000.123456) vcan0 12345678#00         29-bit id (8 hex digits)
//   (1700000000.123456) vcan0 123##1DEADBEEF      CAN FD frame: flags nibble (1 = BRS, 2 = ESI), then data
//   (1700000000.123456) vcan0 123#R               remote request
// Error frames are written with CAN_ERR_FLAG (0x20000000) in the 8-digit id, as candump does.
#include "emadiag/can/can_frame.hpp"

#include <chrono>
#include <fstream>
#include <functional>
#include <iosfwd>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace emadiag::can {

inline constexpr std::uint32_t kCanErrFlag = 0x20000000u;

struct CandumpRecord {
    CanFrame frame;
    std::string iface;
};

[[nodiscard]] std::string format_candump_line(const CanFrame& frame, const std::string& iface);
/// Parses one line; on failure returns nullopt and puts the reason (with the column) in `error`.
[[nodiscard]] std::optional<CandumpRecord> parse_candump_line(std::string_view line, std::string& error);
/// Limits of the readers (docs/limits.md): the longest line (the longest valid line, a CAN FD
/// frame with a 29-bit id and 64 bytes, is about 200 bytes), the bad lines listed in one error
/// (all are counted), and the frames of a log held in memory by read_candump / read_candump_file.
inline constexpr std::size_t kCandumpMaxLineBytes = 1024;
inline constexpr std::size_t kCandumpMaxReportedErrors = 20;
inline constexpr std::size_t kCandumpMaxRecords = 1'000'000;

/// Streams a log: calls `on_record` for each good line in order, in memory bounded by one line.
/// Afterwards throws CanError listing the bad lines as "name:line:col: message" (the first
/// kCandumpMaxReportedErrors, and how many there were). Empty lines are skipped.
void for_each_candump_record(std::istream& in, const std::string& name, const std::function<void(CandumpRecord&&)>& on_record);
/// Reads a whole log into memory (at most kCandumpMaxRecords frames); throws CanError listing the
/// bad lines as for_each_candump_record does.
[[nodiscard]] std::vector<CandumpRecord> read_candump(std::istream& in, const std::string& name);
[[nodiscard]] std::vector<CandumpRecord> read_candump_file(const std::string& path);

/// How much a CandumpWriter holds in memory before it writes to the file: whichever bound is
/// reached first. A process killed outright loses at most this much of the log's tail.
struct CandumpWriterBounds {
    std::size_t max_buffered_bytes = std::size_t{64} << 10;
    std::chrono::milliseconds max_buffered_time{200};
};

/// Appends frames to a candump log, one line each. Lines are buffered and written in one call
/// when a bound of CandumpWriterBounds is reached, on flush() and on destruction (every exit
/// path, exceptions included), so the file is complete and byte-exact once the writer is gone.
class CandumpWriter {
public:
    /// Creates or truncates `path`; throws CanError naming the path when it cannot be opened, or when
    /// it is a link, a device, a FIFO or a directory (emadiag/io/output_path.hpp; opened with
    /// O_NOFOLLOW | O_NONBLOCK and checked again on the open file, so nothing is written through a
    /// link and a FIFO never blocks). The log is written in place, not renamed at the end: a recording
    /// cut short keeps every frame flushed so far.
    explicit CandumpWriter(const std::string& path, CandumpWriterBounds bounds = {});
    ~CandumpWriter();
    CandumpWriter(const CandumpWriter&) = delete;
    CandumpWriter& operator=(const CandumpWriter&) = delete;
    void write(const CanFrame& frame, const std::string& iface);
    /// Writes what is buffered; throws CanError naming the path when the file cannot take it.
    void flush();
    [[nodiscard]] const std::string& path() const { return path_; }
    [[nodiscard]] std::size_t lines() const { return lines_; }

private:
    std::string path_;
    CandumpWriterBounds bounds_;
    int fd_ = -1;
    std::string buffer_;
    std::chrono::steady_clock::time_point last_flush_;
    std::size_t lines_ = 0;
};

}  // namespace emadiag::can
