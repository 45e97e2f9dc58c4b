#pragma once
// The test sequence on the bus (ema_icd's TestSequence: DYN, BRK) and the run's sequence
// (sim::Sequence): the one mapping between them. Text is sim::to_string / sim::parse_sequence.
#include "core/emadiag_error.hpp"
#include "emadiag/can/ema_icd.hpp"
#include "emadiag/sim/simulator.hpp"

namespace emadiag::can_tool {

/// The run's sequence of a START_SEQUENCE command: BRK is BRK, anything else is run as DYN (the
/// EMA node's rule, sim_backend/node).
[[nodiscard]] inline sim::Sequence run_sequence_of(can::icd::TestSequence s) {
    return s == can::icd::TestSequence::Brk ? sim::Sequence::Brk : sim::Sequence::Dyn;
}

/// The bus's test sequence for a run's sequence; throws EmadiagError for the sweep, which the bus
/// cannot start.
[[nodiscard]] inline can::icd::TestSequence test_sequence_of(sim::Sequence s) {
    switch (s) {
        case sim::Sequence::Dyn: return can::icd::TestSequence::Dyn;
        case sim::Sequence::Brk: return can::icd::TestSequence::Brk;
        case sim::Sequence::Sweep: break;
    }
    throw EmadiagError("the " + sim::to_string(s) + " sequence cannot be started over CAN (TOOL_Command START_SEQUENCE: dyn or brk)");
}

}  // namespace emadiag::can_tool
