#pragma once
// candump log files, as written by `candump -l` and read by `canplayer`:
//   (1700000000.123456) vcan0 123#DEADBEEF        classic frame (3 hex digits: 11-bit id)
//   (1700000000.123456) vcan0 12345678#00         29-bit id (8 hex digits)
//   (1700000000.123456) vcan0 123##1DEADBEEF      CAN FD frame: flags nibble (1 = BRS, 2 = ESI), then data
//   (1700000000.123456) vcan0 123#R               remote request
//   (1700000000.123456) vcan0 123#1122334455667788_E   8 bytes with a raw DLC (candump -8): kept, the DLC ignored
// Error frames are written with CAN_ERR_FLAG (0x20000000) in the 8-digit id, as candump does.
// Lines not starting with '(' are comments to canplayer (candump writes "DROPCOUNT: ..." notices);
// CAN XL lines ("242#80:03:00000242#...") are recognised and skipped, never read as data.
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
    std::uint8_t raw_dlc = 0;  ///< the "_E"-style raw DLC (9..15) of an 8-byte classic frame; 0 = none
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

/// What a log held besides its frames, and what was skipped (issue 25 part 4).
struct CandumpReport {
    std::size_t lines = 0;             ///< lines read, blank ones included
    std::size_t frames = 0;            ///< data and remote frames delivered (classic and CAN FD)
    std::size_t fd_frames = 0;         ///< of which CAN FD
    std::size_t remote_frames = 0;     ///< of which remote requests
    std::size_t error_frames = 0;      ///< error frames delivered (CanFrame::error), not counted in `frames`
    std::size_t skipped_lines = 0;     ///< torn or malformed lines skipped (lenient reading)
    std::size_t can_xl_lines = 0;      ///< CAN XL frames skipped (not supported)
    std::size_t raw_dlc_suffixes = 0;  ///< "_E"-style raw DLCs ignored (their 8 data bytes are kept)
    std::size_t dropcount_lines = 0;   ///< candump's own "DROPCOUNT:" notices
    std::uint64_t frames_dropped_by_candump = 0;  ///< the frames those notices say candump lost
    std::size_t time_steps_back = 0;   ///< lines whose timestamp is earlier than the line before
    bool last_line_torn = false;       ///< the last line was bad and had no final newline (a cut recording)
    /// One line each, "name:line:col: what was wrong; skipped" or a note; at most
    /// kCandumpMaxReportedErrors, `messages_left_out` says how many more there were.
    std::vector<std::string> messages;
    std::size_t messages_left_out = 0;
    /// Nothing skipped, ignored or noted.
    [[nodiscard]] bool clean() const { return messages.empty() && messages_left_out == 0; }
    /// A one-line count: "2080 frames (12 CAN FD, 1 remote), 6 error frames; skipped 1 torn or malformed line, 1 CAN XL line".
    [[nodiscard]] std::string summary() const;
};

/// Strict: a torn or malformed line refuses the whole log (CanError listing the bad lines).
/// Lenient: it is skipped and reported, and every good frame is kept (a session's log, issue 25).
enum class CandumpMode { Strict, Lenient };

/// Streams a log: calls `on_record` for each good line in order, in memory bounded by one line.
/// Both modes refuse plain `candump can0` console output with the hint to record with `candump -l`,
/// and a log in which no line is good (CanError). Strict: afterwards throws CanError listing the bad
/// lines as "name:line:col: message" (the first kCandumpMaxReportedErrors, and how many there were).
/// Empty lines are skipped; CAN XL lines and DROPCOUNT notices are skipped with a message.
CandumpReport for_each_candump_record(std::istream& in, const std::string& name, const std::function<void(CandumpRecord&&)>& on_record,
                                      CandumpMode mode = CandumpMode::Strict);
/// Reads a whole log into memory (at most kCandumpMaxRecords frames); throws CanError listing the
/// bad lines as for_each_candump_record does in `mode`; `report`, when given, gets what was skipped.
[[nodiscard]] std::vector<CandumpRecord> read_candump(std::istream& in, const std::string& name, CandumpMode mode = CandumpMode::Strict,
                                                      CandumpReport* report = nullptr);
[[nodiscard]] std::vector<CandumpRecord> read_candump_file(const std::string& path, CandumpMode mode = CandumpMode::Strict,
                                                           CandumpReport* report = nullptr);

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
