#pragma once
// A long history on one page, the way a reliability engineer reads it (docs/report-html.md, "Long
// histories"). A section with more than HistoryLimits::full_max sessions is summarised by the HTML
// writer, nothing being dropped from the document:
//   - its session table lists the `recent` most recent sessions, every session whose verdict is not
//     SERVICEABLE and the session after each of those (where the verdict changed back);
//   - each plot draws as measured the points of those sessions and both points of every crossing of the
//     limit (a point on one side, its neighbour on the other); all older points lie inside a min/max
//     envelope of their 95 % bars, one step per time column (`columns` across the older span), with
//     the mean of each column as a line;
//   - the page says so, and where all the sessions are (a link to a list beside it, or the command that
//     lists them).
#include "report/report_document.hpp"
#include "report/svg_plot.hpp"

#include <cstddef>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace emadiag::report {

/// The verdict of a session that needs no attention; any other verdict is always listed.
inline constexpr const char* kServiceableVerdict = "SERVICEABLE";

struct HistoryLimits {
    std::size_t full_max = 400;  ///< a section with at most this many sessions is shown whole
    std::size_t recent = 40;     ///< above it: this many most recent sessions listed and plotted as measured
    std::size_t columns = 100;   ///< the older points of each plot: an envelope of this many time columns
};

/// True when `s` has more sessions than limits.full_max.
[[nodiscard]] bool summarised(const ReportSection& s, const HistoryLimits& limits);

/// Indices into s.sessions (oldest first, ascending) of the sessions a summarised section lists: the
/// `recent` last, every one whose verdict is not SERVICEABLE and the one after each of those.
[[nodiscard]] std::vector<std::size_t> listed_sessions(const ReportSection& s, const HistoryLimits& limits);

/// What a summarised section's plot of one parameter draws.
struct PlotSummary {
    ReportParameter shown;            ///< the parameter with only the points drawn as measured
    std::optional<Band> envelope;     ///< the 95 % bars of every point older than the recent ones, per column
    std::optional<LineSeries> means;  ///< the mean value of each column
    std::size_t enveloped = 0;        ///< points inside the envelope and not drawn as measured
};

/// The plot data of `p` (points oldest first) in a summarised section: `listed_ids` are the ids of the
/// listed sessions (their points are drawn as measured, and so are the last `recent` points and both
/// points of every limit crossing).
[[nodiscard]] PlotSummary summarise_plot(const ReportParameter& p, const std::set<std::string>& listed_ids, const HistoryLimits& limits);

/// Every session of `s` as CSV (RFC 4180: a header row, fields with a comma, quote or line break
/// quoted, quotes doubled), oldest first, the columns of the HTML session table.
[[nodiscard]] std::string sessions_csv(const ReportSection& s);

}  // namespace emadiag::report
