#pragma once
// The maintenance record of one aircraft (prognostics::FleetRecord, `emadiag report`) as a
// ReportDocument for the HTML writer: per position and per actuator serial the installations, the
// session history, each parameter's trend with its fit, 90 % band and limit, the RUL with its 90 %
// interval in flight cycles and days, the health index and status, and the open discovery findings.
// The plots' time axis is flight cycles when every trend of the record prefers cycles (every session
// carries them), else dates; the RUL table gives both units either way.
#include "prognostics/fleet_record.hpp"
#include "report/report_document.hpp"
#include "report/trend_adapter.hpp"

namespace emadiag::report {

/// The document of `record`. Throws EmadiagError on an unknown parameter name.
[[nodiscard]] ReportDocument from_fleet_record(const prognostics::FleetRecord& record, const TrendAdapterOptions& options);

}  // namespace emadiag::report
