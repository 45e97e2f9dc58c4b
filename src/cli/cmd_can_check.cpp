// emadiag can-check [--strict] FILE...: what a DBC file or a candump log holds and what reading it
// skipped (issue 25 part 4). A DBC: its messages and signals, the warnings of lenient reading (file,
// line, what was skipped or kept) and whether it carries the EMA ICD the tool needs (--dbc); a log:
// its frames by kind, interfaces, time span, the frames of the ICD, and every line skipped.
// Exit 0 when every file was read, 1 when one was refused (each refusal says file:line:column).
#include "cli/command.hpp"

#include "emadiag/can/can_error.hpp"
#include "emadiag/can/candump_log.hpp"
#include "emadiag/can/dbc.hpp"
#include "emadiag/can/ema_icd.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <set>

namespace emadiag::cli {
namespace {

bool is_dbc_path(const std::string& path) {
    if (path.size() < 4) return false;
    std::string ext = path.substr(path.size() - 4);
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext == ".dbc";
}

void check_dbc(const std::string& path, bool strict) {
    const can::Database db = can::parse_dbc_file(path, strict ? can::DbcMode::Strict : can::DbcMode::Lenient);
    std::size_t signals = 0, fd = 0, extended = 0, multiplexed = 0, tables = 0;
    for (const auto& m : db.messages) {
        signals += m.signals.size();
        fd += m.is_fd ? 1 : 0;
        extended += m.extended ? 1 : 0;
        bool mux = false;
        for (const auto& s : m.signals) {
            mux = mux || s.mux_role != can::MuxRole::None;
            tables += s.value_table.empty() ? 0 : 1;
        }
        multiplexed += mux ? 1 : 0;
    }
    std::cout << path << ": DBC, read " << (strict ? "strictly" : "leniently") << ": " << db.messages.size() << " messages (" << fd
              << " CAN FD, " << extended << " with 29-bit ids, " << multiplexed << " multiplexed), " << signals << " signals, " << tables
              << " with value tables, " << db.nodes.size() << " nodes; " << db.warnings.size() << " warning"
              << (db.warnings.size() == 1 ? "" : "s") << '\n';
    for (const auto& w : db.warnings) std::cout << "  warning: " << w << '\n';
    const auto missing = can::missing_icd_items(db);
    if (missing.empty()) {
        std::cout << "  EMA ICD: complete (usable as --dbc " << path << ")\n";
    } else {
        std::cout << "  EMA ICD: lacks " << missing.size() << " of the messages and signals the tool needs (not usable as --dbc)";
        const std::size_t shown = std::min<std::size_t>(missing.size(), 8);
        for (std::size_t i = 0; i < shown; ++i) std::cout << (i == 0 ? ": " : ", ") << missing[i];
        std::cout << (missing.size() > shown ? ", ..." : "") << '\n';
    }
}

std::string seconds_text(std::chrono::nanoseconds t) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%lld.%06lld", static_cast<long long>(t.count() / 1000000000LL),
                  static_cast<long long>((t.count() % 1000000000LL) / 1000));
    return buf;
}

void check_log(const std::string& path, bool strict) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw can::CanError(path + ": cannot open the candump log");
    const can::Database& icd = can::ema_database();
    std::set<std::string> ifaces;
    std::set<std::pair<std::uint32_t, bool>> ids;
    std::size_t icd_frames = 0;
    std::optional<std::chrono::nanoseconds> first, last;
    const can::CandumpReport rep = can::for_each_candump_record(
        in, path,
        [&](can::CandumpRecord&& r) {
            if (ifaces.size() < 64) ifaces.insert(r.iface);
            if (r.frame.error) return;
            ids.emplace(r.frame.id, r.frame.extended);
            if (icd.find_message(r.frame.id, r.frame.extended) != nullptr) ++icd_frames;
            if (!first) first = r.frame.timestamp;
            last = r.frame.timestamp;
        },
        strict ? can::CandumpMode::Strict : can::CandumpMode::Lenient);
    std::cout << path << ": candump log, " << rep.lines << " lines: " << rep.summary() << '\n';
    if (first) {
        std::string names;
        for (const auto& i : ifaces) names += (names.empty() ? "" : ", ") + i;
        std::cout << "  " << ids.size() << " distinct ids on " << names << "; time " << seconds_text(*first) << " to " << seconds_text(*last)
                  << "; " << icd_frames << " frames of the EMA ICD\n";
    }
    for (const auto& m : rep.messages) std::cout << "  " << m << '\n';
    if (rep.messages_left_out > 0) std::cout << "  ... and " << rep.messages_left_out << " more not listed\n";
}

const bool registered = register_command(Command{
    "can-check", "Say what DBC files and candump logs hold and what reading them skipped",
    [](CLI::App& sub) -> std::function<int()> {
        auto files = std::make_shared<std::vector<std::string>>();
        auto strict = std::make_shared<bool>(false);
        sub.add_option("files", *files, "DBC files (*.dbc) and candump logs (anything else)")->required();
        sub.add_flag("--strict", *strict, "refuse what lenient reading skips with a warning (cantools strict=True; a bad log line)");
        return [files, strict] {
            int refused = 0;
            for (const auto& path : *files) {
                try {
                    if (is_dbc_path(path)) check_dbc(path, *strict);
                    else check_log(path, *strict);
                } catch (const can::CanError& e) {
                    ++refused;
                    std::cout << path << ": refused\n  " << e.what() << '\n';
                }
            }
            std::cout << "can-check: " << files->size() - static_cast<std::size_t>(refused) << " read, " << refused << " refused\n";
            return refused == 0 ? 0 : 1;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
