// DBC parser, multiplexing and the final checks: SG_MUL_VAL_, the switch of simple multiplexing,
// multiplexing that cannot be evaluated (refused), switches not marked as multiplexors, and the
// long names that replace names cut to 32 characters.
#include "dbc_parser.hpp"

#include <algorithm>

namespace emadiag::can::detail {

void Parser::extended_multiplexing() {
    next();
    const Token at = peek();
    Message* m = message_by_id(at, unsigned_int("message id"));
    const Token sat = peek();
    Signal* s = signal_of(m, sat, ident("multiplexed signal name"));
    const Token swt = peek();
    const std::string sw = ident("multiplexor switch name");
    std::vector<MuxRange> ranges;
    do {
        const std::uint64_t lo = unsigned_int("range start");
        const Token ht = peek();
        if (ht.kind != Tok::Number || ht.text[0] != '-') fail(ht, "'-' and the range end");
        std::uint64_t hi = 0;
        if (!parse_decimal_u64(std::string_view(ht.text).substr(1), hi))
            throw SyntaxError{ht.line, ht.col, "invalid multiplexor range end '" + ht.text.substr(1) + "' (expected an unsigned integer)"};
        next();
        if (hi < lo) error(ht, "multiplexor range " + std::to_string(lo) + "-" + std::to_string(hi) + " is empty");
        ranges.push_back(MuxRange{lo, hi});
    } while (accept_punct(","));
    expect_semicolon();
    if (s == nullptr) return;
    if (m->find_signal(sw) == nullptr) {
        error(swt, "message '" + m->name + "' has no multiplexor switch '" + sw + "' (multiplexing that cannot be evaluated)");
        return;
    }
    s->multiplexor = sw;
    mux_pos_[m->name + "." + s->name] = swt;
    if (!extended_mux_seen_.count(s)) s->mux_ranges.clear();
    extended_mux_seen_.insert(s);
    s->mux_ranges.insert(s->mux_ranges.end(), ranges.begin(), ranges.end());
    if (s->mux_role == MuxRole::None) s->mux_role = MuxRole::Multiplexed;
}

void Parser::finish() {
    const auto cycle_def = db_.attribute_definitions.find("GenMsgCycleTime");
    const auto format_def = db_.attribute_definitions.find("VFrameFormat");
    for (auto& m : db_.messages) {
        // Simple multiplexing: mN signals without SG_MUL_VAL_ use the message's M switch.
        const Signal* switch_sig = nullptr;
        int switches = 0;
        for (const auto& s : m.signals)
            if (s.mux_role == MuxRole::Multiplexor) {
                switch_sig = &s;
                ++switches;
            }
        std::set<std::string> orphans;  // lenient: multiplexed signals without a multiplexor, never decoded
        for (auto& s : m.signals) {
            if ((s.mux_role == MuxRole::Multiplexed || s.mux_role == MuxRole::MultiplexedMultiplexor) && s.multiplexor.empty()) {
                const Token& at = signal_pos_[m.name + "." + s.name];
                if (switch_sig == nullptr) {
                    soft(at, "signal '" + s.name + "' is multiplexed but message '" + m.name + "' has no multiplexor (M) signal", "signal skipped");
                    orphans.insert(s.name);
                }
                else if (switches > 1) error(at, "signal '" + s.name + "': message '" + m.name + "' has several multiplexors; SG_MUL_VAL_ must name the switch");
                else s.multiplexor = switch_sig->name;
            }
        }
        check_multiplexing(m);
        // A switch named by SG_MUL_VAL_ that is not a multiplexor (M or mNM): cantools never
        // decodes the signals it would select (nor those they select in turn).
        for (bool more = true; more;) {
            more = false;
            for (const auto& s : m.signals) {
                if (s.multiplexor.empty() || orphans.count(s.name)) continue;
                const Signal* sw = m.find_signal(s.multiplexor);
                if (sw == nullptr || sw == &s) continue;  // refused by check_multiplexing
                if (orphans.count(sw->name)) {
                    orphans.insert(s.name);
                    more = true;
                } else if (sw->mux_role != MuxRole::Multiplexor && sw->mux_role != MuxRole::MultiplexedMultiplexor) {
                    soft(mux_position(m, s), "signal '" + s.name + "': its multiplexor '" + sw->name + "' is not marked as a multiplexor (M)",
                         "signal skipped");
                    orphans.insert(s.name);
                    more = true;
                }
            }
        }
        if (!orphans.empty())
            m.signals.erase(std::remove_if(m.signals.begin(), m.signals.end(), [&](const Signal& s) { return orphans.count(s.name) > 0; }),
                            m.signals.end());
        apply_long_names(m);
        if (auto it = m.attributes.find("GenMsgCycleTime"); it != m.attributes.end()) m.cycle_time_ms_ = it->second.number;
        else if (cycle_def != db_.attribute_definitions.end() && cycle_def->second.default_value)
            m.cycle_time_ms_ = cycle_def->second.default_value->number;
        std::string format;
        if (auto it = m.attributes.find("VFrameFormat"); it != m.attributes.end()) format = it->second.text;
        else if (format_def != db_.attribute_definitions.end() && format_def->second.default_value)
            format = format_def->second.default_value->text;
        if (format.find("CANFD") != std::string::npos) m.is_fd = true;
    }
}

/// The position to name for a signal's multiplexing: its SG_MUL_VAL_, else its SG_ line.
const Token& Parser::mux_position(const Message& m, const Signal& s) {
    const std::string key = m.name + "." + s.name;
    if (auto it = mux_pos_.find(key); it != mux_pos_.end()) return it->second;
    return signal_pos_[key];
}

/// Multiplexing that cannot be evaluated is refused in both modes (issue 25 part 3): a signal
/// multiplexed by itself, a multiplexor that is not in the message, or a cycle of multiplexors
/// (Message::is_active follows the chain and would never end).
void Parser::check_multiplexing(const Message& m) {
    const std::size_t n = m.signals.size();
    std::map<std::string_view, std::size_t> index;
    for (std::size_t i = 0; i < n; ++i) index.emplace(m.signals[i].name, i);
    constexpr std::size_t kNone = static_cast<std::size_t>(-1);
    std::vector<std::size_t> parent(n, kNone);
    for (std::size_t i = 0; i < n; ++i) {
        const Signal& s = m.signals[i];
        if (s.multiplexor.empty()) continue;
        if (s.multiplexor == s.name) {
            error(mux_position(m, s), "signal '" + s.name + "' of message '" + m.name + "' is multiplexed by itself (multiplexing that cannot be evaluated)");
        } else if (auto it = index.find(s.multiplexor); it == index.end()) {
            error(mux_position(m, s), "signal '" + s.name + "': its multiplexor '" + s.multiplexor + "' is not in message '" + m.name + "'");
        } else {
            parent[i] = it->second;
        }
    }
    // Each signal's chain of multiplexors, followed once (0 = not seen, 1 = on the current path, 2 = done).
    std::vector<int> state(n, 0);
    for (std::size_t i = 0; i < n; ++i) {
        std::vector<std::size_t> path;
        std::size_t j = i;
        while (j != kNone && state[j] == 0) {
            state[j] = 1;
            path.push_back(j);
            j = parent[j];
        }
        if (j != kNone && state[j] == 1) {  // a cycle: the part of the path from j
            std::string names;
            const auto from = std::find(path.begin(), path.end(), j);
            for (auto k = from; k != path.end(); ++k) names += m.signals[*k].name + " -> ";
            names += m.signals[j].name;
            error(mux_position(m, m.signals[j]), "signal '" + m.signals[j].name + "' of message '" + m.name +
                                                     "': its multiplexors form a cycle (" + names + "), multiplexing that cannot be evaluated");
        }
        for (std::size_t k : path) state[k] = 2;
    }
}

/// The long name CANdb++ keeps for a name cut to 32 characters: the SystemSignalLongSymbol /
/// SystemMessageLongSymbol attribute (what cantools reads), else ...LongName; empty when none.
std::string Parser::long_name(const std::map<std::string, AttributeValue>& attributes, const char* symbol, const char* name) {
    for (const char* key : {symbol, name})
        if (auto it = attributes.find(key); it != attributes.end() && it->second.is_string && !it->second.text.empty()) return it->second.text;
    return {};
}

/// Long names replace the DBC names (at most 32 characters), as cantools does; multiplexor
/// references follow the new names. A long name already used in its message (or among the
/// messages) is a warning, and the short name stays.
void Parser::apply_long_names(Message& m) {
    std::map<std::string, std::string> renamed;
    for (auto& s : m.signals) {
        const std::string longer = long_name(s.attributes, "SystemSignalLongSymbol", "SystemSignalLongName");
        if (longer.empty() || longer == s.name) continue;
        if (m.find_signal(longer) != nullptr) {
            soft(signal_pos_[m.name + "." + s.name], "signal '" + s.name + "': long name '" + longer + "' is already a signal of message '" + m.name + "'",
                 "short name kept");
            continue;
        }
        renamed[s.name] = longer;
        s.name = longer;
    }
    for (auto& s : m.signals)
        if (auto it = renamed.find(s.multiplexor); it != renamed.end()) s.multiplexor = it->second;
    const std::string longer = long_name(m.attributes, "SystemMessageLongSymbol", "SystemMessageLongName");
    if (longer.empty() || longer == m.name) return;
    if (db_.find_message(longer) != nullptr)
        soft(message_pos_[m.name], "message '" + m.name + "': long name '" + longer + "' is already a message name", "short name kept");
    else m.name = longer;
}

}  // namespace emadiag::can::detail
