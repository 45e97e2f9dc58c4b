#pragma once
// Turns the frames of one test session (both directions) into a Run: constants from EMA_Ident,
// the sequence from the tool's START_SEQUENCE, the load case from EMA_Status, and one row per
// sample whose two telemetry frames both arrived with a good CRC. Missing or corrupt samples are
// counted and left out, never interpolated; above kMaxLossFraction the run is marked invalid.
#include "core/run.hpp"

#include "emadiag/can/ema_icd.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace emadiag::can_tool {

/// Above this fraction of lost or corrupt telemetry frames a run is invalid (issue 3 part 5).
inline constexpr double kMaxLossFraction = 0.001;

struct SessionStats {
    std::uint64_t samples_expected = 0;  ///< max(final SamplesSent, highest index + 1)
    std::uint64_t samples_complete = 0;  ///< both halves present with a good CRC
    std::uint64_t frames_expected = 0;   ///< 2 per expected sample
    std::uint64_t frames_received = 0;   ///< telemetry frames received (good or bad CRC)
    std::uint64_t frames_lost = 0;       ///< expected frames that never arrived
    std::uint64_t crc_failures = 0;      ///< telemetry frames whose CRC-8 did not match
    std::uint64_t counter_gaps = 0;      ///< frames missing according to the 4-bit rolling counters
    std::uint64_t duplicates = 0;        ///< telemetry frames repeating an index already received
    [[nodiscard]] double loss_fraction() const {
        return frames_expected == 0 ? 0.0 : static_cast<double>(frames_lost + crc_failures) / static_cast<double>(frames_expected);
    }
};

class SessionDecoder {
public:
    SessionDecoder();
    /// Feeds one frame; `now_ms` is not needed, order is. Frames of a new START_SEQUENCE reset the
    /// telemetry (one log holds one run: the last one started).
    void feed(const can::CanFrame& frame);

    [[nodiscard]] bool ident_complete() const { return ident_.complete(); }
    [[nodiscard]] const can::EmaIdentification& ident() const { return ident_.identification(); }
    [[nodiscard]] const std::optional<can::EmaStatus>& last_status() const { return last_status_; }
    [[nodiscard]] const std::optional<can::ToolCommand>& start_command() const { return start_; }
    [[nodiscard]] bool abort_sent() const { return abort_sent_; }
    [[nodiscard]] SessionStats stats() const;
    [[nodiscard]] std::uint64_t frames_seen() const { return frames_seen_; }

    /// Builds the run; throws EmadiagError naming what the log lacks (identification, start command).
    /// `status` is "complete", "aborted" or "incomplete"; the meta gets valid=true/false and the counts.
    [[nodiscard]] Run build_run(const std::string& source) const;

    const can::EmaIcd icd;

private:
    struct Half {
        bool present = false;
        bool crc_ok = false;
        double v1 = 0, v2 = 0;
    };
    can::IdentAssembler ident_;
    std::optional<can::EmaStatus> last_status_;
    std::optional<can::ToolCommand> start_;
    bool abort_sent_ = false;
    std::vector<Half> a_, b_;
    std::uint64_t received_ = 0, crc_failures_ = 0, counter_gaps_ = 0, duplicates_ = 0, frames_seen_ = 0;
    int last_counter_a_ = -1, last_counter_b_ = -1;
};

}  // namespace emadiag::can_tool
