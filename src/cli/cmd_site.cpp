// emadiag site --db D --out DIR [--draws 4000] [--fleet-draws 1000] [--seed 1] [--threads N]
//              [--full-history-max 400] [--recent-sessions 40]:
// the fleet as a static, self-contained web site (issue 26, docs/install.md): DIR/index.html ranks
// every tail and position as `fleet` ranks them and links each to its tail's page, and
// DIR/tails/tail-<name>.html is the tail's HTML maintenance report (`report --format html`) with a link
// back to the index. A position or serial with a long history is summarised on that page
// (report/history_summary.hpp) and every one of its sessions is in tails/tail-<name>.<anchor>.csv,
// which the page links. No script, no network reference (each page carries the report's
// Content-Security-Policy default-src 'none'), only relative links between the pages.
// Written safely: the site is built in a fresh folder beside DIR and moved into place whole; an
// existing DIR is replaced only when it holds nothing but an earlier site (its marker file, index.html,
// tails/tail-*.html and tails/tail-*.csv), otherwise refused. Tail numbers become file names by escaping every byte
// other than [A-Za-z0-9-] as _XX (hex), so no name can leave tails/ or collide with another.
#include "cli/command.hpp"
#include "cli/db_source.hpp"
#include "cli/site_file_name.hpp"

#include "core/emadiag_error.hpp"
#include "prognostics/fleet_record.hpp"
#include "prognostics/fleet_view.hpp"
#include "prognostics/utc_time.hpp"
#include "report/html_report.hpp"
#include "report/record_adapter.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

namespace emadiag::cli {
namespace {

namespace pg = emadiag::prognostics;
namespace fs = std::filesystem;

/// The file that marks a folder as a site this command wrote (what may be replaced).
constexpr const char* kSiteMarker = ".emadiag-site";
constexpr const char* kIndexFile = "index.html";
constexpr const char* kTailFolder = "tails";
/// Where the tail page's own markup begins: the site's navigation goes right after it.
constexpr const char* kBodyOpen = "<body>\n";
constexpr unsigned kMaxThreads = 256;
/// The most sessions a page may be asked to list before summarising (or as the recent ones).
constexpr std::size_t kMaxListedSessions = 1000000;
constexpr const char* kSitePolicy = "default-src 'none'; style-src 'unsafe-inline'";

struct SiteCliOptions {
    std::string db = "maintenance.db";
    std::string out;
    pg::FleetRecordOptions record;
    pg::FleetOptions fleet;
    report::HistoryLimits history;  ///< when a tail page summarises a section (report/history_summary.hpp)
    unsigned threads = 0;           ///< 0: one per core
};

/// One new file of the site in its fresh staging folder: written plainly (no temporary, no fsync of
/// its own; the staging folder is fresh and nothing else writes there). sync_site flushes them all
/// at once before the site is moved into place.
void write_site_file(const fs::path& path, const std::string& text) {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0) throw EmadiagError("site: cannot create " + path.string() + ": " + std::strerror(errno));
    std::size_t done = 0;
    while (done < text.size()) {
        const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            const int e = errno;
            ::close(fd);
            throw EmadiagError("site: cannot write " + path.string() + " (" + std::to_string(done) + " of " + std::to_string(text.size()) +
                               " bytes): " + std::strerror(e));
        }
        done += static_cast<std::size_t>(n);
    }
    if (::close(fd) != 0) throw EmadiagError("site: cannot write " + path.string() + " (close): " + std::strerror(errno));
}

/// Every file of the staging folder on disk (one syncfs for the thousands of pages, instead of an
/// fsync each) before the folder is renamed into place.
void sync_site(const fs::path& dir) {
    const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) throw EmadiagError("site: cannot open " + dir.string() + " to flush it: " + std::strerror(errno));
    const int rc = ::syncfs(fd);
    const int e = errno;
    ::close(fd);
    if (rc != 0) throw EmadiagError("site: cannot flush " + dir.string() + " to disk (syncfs): " + std::strerror(e));
}

/// What the index needs of each tail's page: its file and the anchor of each position's section.
struct TailPage {
    std::string file;
    std::map<std::string, std::string> position_anchor;
    std::size_t bytes = 0;
    std::size_t lists = 0, list_bytes = 0;  ///< the CSV lists of its summarised sections
};

/// The file of the list of every session of a summarised section, beside the tail's page:
/// tail-<name>.<anchor>.csv (the escaped name holds no '.', so no tail's files collide with another's).
std::string list_file_name(const std::string& page_file, const std::string& anchor) {
    return page_file.substr(0, page_file.size() - std::string(kSitePageExtension).size()) + "." + anchor + kSiteListExtension;
}

/// Writes the CSV list of each summarised section of `d` beside its page (a serial section holding
/// the same sessions as a position's links that position's list) and returns the links for the page.
report::HtmlOptions write_lists(const report::ReportDocument& d, const report::HistoryLimits& history, const fs::path& folder, TailPage& page) {
    report::HtmlOptions opt;
    opt.history = history;
    std::vector<std::pair<std::vector<std::string>, std::string>> written;  // session ids, file
    const auto one = [&](const report::ReportSection& s, std::size_t i) {
        if (!report::summarised(s, opt.history)) return;
        const std::string anchor = report::section_anchor(s, i);
        std::vector<std::string> ids;
        ids.reserve(s.sessions.size());
        for (const auto& x : s.sessions) ids.push_back(x.id);
        for (const auto& [same, file] : written)
            if (same == ids) {
                opt.full_history_href[anchor] = file;
                return;
            }
        const std::string file = list_file_name(page.file, anchor);
        const std::string csv = report::sessions_csv(s);
        write_site_file(folder / file, csv);
        ++page.lists;
        page.list_bytes += csv.size();
        opt.full_history_href[anchor] = file;
        written.emplace_back(std::move(ids), file);
    };
    for (std::size_t i = 0; i < d.positions.size(); ++i) one(d.positions[i], i);
    for (std::size_t i = 0; i < d.serials.size(); ++i) one(d.serials[i], i);
    return opt;
}

std::string esc(const std::string& s) { return report::html_escape(s); }


std::string days(const std::optional<double>& v) {
    if (!v) return "beyond horizon";
    std::ostringstream os;
    os << std::fixed << std::setprecision(0) << *v;
    return os.str();
}

std::string status_class(const pg::FleetRow& r) {
    if (r.status == "limit exceeded") return "bad";
    if (r.status == "crossing predicted") return "warn";
    if (r.status == "no crossing within the horizon") return "ok";
    return "none";
}

constexpr const char* kSiteStyle = R"(
body { font-family: sans-serif; font-size: 14px; color: #222; margin: 16px 24px; max-width: 1240px; }
h1 { font-size: 22px; margin: 0 0 4px 0; }
h2 { font-size: 18px; border-bottom: 2px solid #34495e; padding-bottom: 2px; margin-top: 28px; }
.meta, .note { color: #555; }
table { border-collapse: collapse; margin: 8px 0; }
th, td { border: 1px solid #ccc; padding: 3px 8px; text-align: left; }
th { background: #ecf0f1; }
td { white-space: nowrap; }
td.num { text-align: right; }
span.st { padding: 1px 6px; border-radius: 3px; color: #fff; }
span.bad { background: #c0392b; } span.warn { background: #d68910; } span.ok { background: #1e8449; } span.none { background: #7f8c8d; }
ul.tails { columns: 6; list-style: none; padding: 0; }
)";

std::string index_html(const std::vector<pg::FleetRow>& rows, const std::vector<std::string>& tails, const std::map<std::string, TailPage>& pages,
                       const std::string& generated, const SiteCliOptions& o) {
    std::ostringstream os;
    os << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n"
       << "<meta http-equiv=\"Content-Security-Policy\" content=\"" << kSitePolicy << "\"/>\n"
       << "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"/>\n"
       << "<title>emadiag fleet</title>\n<style>" << kSiteStyle << "</style>\n</head>\n<body>\n"
       << "<header>\n<h1>emadiag fleet: " << tails.size() << " tail(s), " << rows.size() << " position(s)</h1>\n"
       << "<p class=\"meta\">generated " << esc(generated) << " &#183; emadiag " << esc(EMADIAG_VERSION) << " &#183; from " << esc(o.db)
       << "</p>\n</header>\n";
    os << "<section>\n<h2>Positions, most urgent first</h2>\n<table>\n<tr><th>rank</th><th>tail</th><th>position</th><th>ATA</th><th>serial</th>"
          "<th>sessions</th><th>last session (UTC)</th><th>last verdict</th><th>status</th><th>RUL 90 % lower (days)</th><th>driven by</th></tr>\n";
    for (const auto& r : rows) {
        const auto page = pages.find(r.tail_number);
        std::string tail_cell = esc(r.tail_number), position_cell = esc(r.position);
        if (page != pages.end()) {
            const std::string href = std::string(kTailFolder) + "/" + page->second.file;
            tail_cell = "<a href=\"" + esc(href) + "\">" + tail_cell + "</a>";
            const auto anchor = page->second.position_anchor.find(r.position);
            if (anchor != page->second.position_anchor.end())
                position_cell = "<a href=\"" + esc(href + "#" + anchor->second) + "\">" + position_cell + "</a>";
        }
        os << "<tr><td class=\"num\">" << r.rank << "</td><td>" << tail_cell << "</td><td>" << position_cell << "</td><td>" << esc(r.ata_reference)
           << "</td><td>" << esc(r.actuator_serial) << "</td><td class=\"num\">" << r.sessions << "</td><td>" << esc(r.last_utc) << "</td><td>"
           << esc(r.last_verdict) << "</td><td><span class=\"st " << status_class(r) << "\">" << esc(r.status) << "</span></td><td class=\"num\">"
           << days(r.urgency_days) << "</td><td>" << esc(r.driving_parameter.empty() ? "-" : r.driving_parameter) << "</td></tr>\n";
    }
    os << "</table>\n</section>\n<section>\n<h2>Tails</h2>\n<ul class=\"tails\">\n";
    for (const auto& t : tails) {
        const auto page = pages.find(t);
        os << "<li>";
        if (page != pages.end())
            os << "<a href=\"" << esc(std::string(kTailFolder) + "/" + page->second.file) << "\">" << esc(t) << "</a>";
        else
            os << esc(t);
        os << "</li>\n";
    }
    os << "</ul>\n</section>\n<footer>\n<p class=\"note\">Ranked as <b>emadiag fleet</b> ranks: the lower bound of the 90 % RUL interval in days "
          "(cycles converted at each position's own rate), then the last verdict; "
       << o.fleet.rul.draws << " Monte Carlo draws, seed " << o.fleet.rul.seed << ". Each tail's page is its maintenance report (emadiag report "
       << "--format html, " << o.record.rul.draws << " draws, seed " << o.record.rul.seed << "); a position or serial with more than "
       << o.history.full_max << " sessions is summarised there, and its page links the CSV list of all its sessions.</p>\n"
       << "</footer>\n</body>\n</html>\n";
    return os.str();
}

/// The tail's report with the site's navigation back to the index.
std::string with_navigation(std::string html, const std::string& tail) {
    const auto at = html.find(kBodyOpen);
    if (at == std::string::npos) throw EmadiagError("site: the report of tail " + tail + " has no <body> to add the navigation to");
    html.insert(at + std::string(kBodyOpen).size(),
                "<nav><a href=\"../" + std::string(kIndexFile) + "\">&#8592; fleet index</a> &#183; tail " + esc(tail) + "</nav>\n");
    return html;
}

/// An existing DIR may be replaced only when it holds nothing but a site this command wrote.
void check_replaceable(const fs::path& dir) {
    std::error_code ec;
    const auto st = fs::symlink_status(dir, ec);
    if (ec || !fs::exists(st)) return;
    if (fs::is_symlink(st)) throw EmadiagError("site: " + dir.string() + " is a symbolic link; give a real folder");
    if (!fs::is_directory(st)) throw EmadiagError("site: " + dir.string() + " exists and is not a folder");
    bool empty = true, marked = false;
    for (const auto& e : fs::directory_iterator(dir)) {
        empty = false;
        const std::string name = e.path().filename().string();
        if (name == kSiteMarker) {
            marked = true;
            continue;
        }
        if (name == kIndexFile && e.is_regular_file() && !e.is_symlink()) continue;
        if (name == kTailFolder && e.is_directory() && !e.is_symlink()) {
            for (const auto& t : fs::directory_iterator(e.path())) {
                const std::string f = t.path().filename().string();
                if (!t.is_regular_file() || t.is_symlink() || f.rfind(kSiteTailFilePrefix, 0) != 0 ||
                    (t.path().extension() != kSitePageExtension && t.path().extension() != kSiteListExtension))
                    throw EmadiagError("site: " + dir.string() + " holds " + t.path().string() +
                                       ", which this command did not write; give a new or empty folder");
            }
            continue;
        }
        throw EmadiagError("site: " + dir.string() + " holds " + e.path().string() +
                           ", which this command did not write; give a new or empty folder");
    }
    if (!empty && !marked)
        throw EmadiagError("site: " + dir.string() + " is not empty and has no " + kSiteMarker + " (not a site this command wrote); give a new or empty folder");
}

/// A fresh folder beside `dir` (same file system, so the final renames are atomic).
fs::path fresh_sibling(const fs::path& dir, const std::string& what) {
    std::string pattern = (dir.has_parent_path() ? dir.parent_path() / dir.filename() : dir).string() + "." + what + "-XXXXXX";
    if (::mkdtemp(pattern.data()) == nullptr) throw EmadiagError("site: cannot create a folder beside " + dir.string() + " (" + pattern + ")");
    // mkdtemp makes it 0700; a site is for reading: the permissions of any new folder (0777 less the umask).
    const mode_t mask = ::umask(0);
    ::umask(mask);
    fs::permissions(pattern, static_cast<fs::perms>(0777 & ~mask));
    return pattern;
}

struct Totals {
    std::size_t files = 0, bytes = 0;  ///< pages (the index and the tails') and the bytes of every file
    std::size_t lists = 0;             ///< the CSV lists of summarised sections
};

Totals write_site(const SiteCliOptions& o, const fs::path& root) {
    db::OpenedSource database = db::open_record_source(o.db);
    const auto rows = pg::build_fleet_view(*database.source, o.fleet);
    const std::vector<std::string> tails = database.source->tail_numbers();
    const std::string generated = pg::now_utc_time();
    fs::create_directory(root / kTailFolder);

    std::map<std::string, TailPage> pages;
    std::mutex mutex;
    std::atomic<std::size_t> next{0};
    std::string first_error;
    // A connection per thread; the calling thread keeps the one it has (each open checks the file).
    const auto work = [&](db::RecordSource* given) {
        try {
            std::optional<db::OpenedSource> opened;
            if (given == nullptr) opened.emplace(db::open_record_source(o.db));
            db::RecordSource& source = given != nullptr ? *given : *opened->source;
            for (std::size_t i = next++; i < tails.size(); i = next++) {
                {
                    const std::lock_guard<std::mutex> lock(mutex);
                    if (!first_error.empty()) return;
                }
                const std::string& tail = tails[i];
                const pg::FleetRecord record = pg::build_fleet_record(source, tail, o.record);
                TailPage page;
                page.file = site_tail_file_name(tail);
                for (std::size_t k = 0; k < record.positions.size(); ++k) page.position_anchor[record.positions[k].key] = "position-" + std::to_string(k + 1);
                const report::ReportDocument document = report::from_fleet_record(record, {generated, EMADIAG_VERSION, o.db});
                const report::HtmlOptions options = write_lists(document, o.history, root / kTailFolder, page);
                const std::string html = with_navigation(report::render_html(document, options), tail);
                write_site_file(root / kTailFolder / page.file, html);
                page.bytes = html.size();
                const std::lock_guard<std::mutex> lock(mutex);
                pages.emplace(tail, std::move(page));
            }
        } catch (const std::exception& e) {
            const std::lock_guard<std::mutex> lock(mutex);
            if (first_error.empty()) first_error = e.what();
        }
    };
    std::vector<std::thread> pool;
    const unsigned wanted = o.threads != 0 ? o.threads : std::max(1u, std::thread::hardware_concurrency());
    const unsigned n = std::max(1u, std::min<unsigned>(wanted, static_cast<unsigned>(std::max<std::size_t>(1, tails.size()))));
    for (unsigned t = 1; t < n; ++t) pool.emplace_back(work, nullptr);
    work(database.source.get());
    for (auto& t : pool) t.join();
    if (!first_error.empty()) throw EmadiagError("site: " + first_error);

    Totals totals;
    for (const auto& [tail, page] : pages) {
        ++totals.files;
        totals.bytes += page.bytes + page.list_bytes;
        totals.lists += page.lists;
    }
    const std::string index = index_html(rows, tails, pages, generated, o);
    write_site_file(root / kIndexFile, index);
    write_site_file(root / kSiteMarker, std::string("emadiag site ") + EMADIAG_VERSION + "\n");
    totals.files += 1;
    totals.bytes += index.size();
    return totals;
}

const bool registered = register_command(Command{
    "site", "Fleet web site: a static, self-contained index ranked as fleet ranks, and each tail's HTML report, linked both ways",
    [](CLI::App& sub) -> std::function<int()> {
        auto o = std::make_shared<SiteCliOptions>();
        sub.add_option("--db", o->db, "Maintenance database: SQLite file, or a fleet server postgresql://... (docs/fleet-server.md)")
            ->capture_default_str()
            ->check(sqlite_file_or_fleet_uri());
        sub.add_option("--out", o->out, "Folder of the site: new, empty, or an earlier site of this command (replaced whole)")->required();
        sub.add_option("--phase", o->record.phase, "Sessions of this phase in the tail pages' trends: all, pre-flight, post-flight, in-flight, load-rig")
            ->capture_default_str();
        sub.add_option("--draws", o->record.rul.draws, "Monte Carlo draws for each tail page's RUL intervals")->capture_default_str();
        sub.add_option("--fleet-draws", o->fleet.rul.draws, "Monte Carlo draws for the index's ranking")->capture_default_str();
        sub.add_option("--seed", o->record.rul.seed, "Seed of the Monte Carlo draws (index and pages)")->capture_default_str();
        sub.add_option("--full-history-max", o->history.full_max,
                       "A position or serial with more sessions is summarised on its tail page (the recent sessions, every one not "
                       "SERVICEABLE, decimated plots) and its page links the CSV list of all its sessions")
            ->capture_default_str()
            ->check(CLI::Range(std::size_t{1}, kMaxListedSessions));
        sub.add_option("--recent-sessions", o->history.recent, "Most recent sessions a summarised section lists and plots as measured")
            ->capture_default_str()
            ->check(CLI::Range(std::size_t{1}, kMaxListedSessions));
        sub.add_option("--threads", o->threads, "Tail pages written in parallel, each with its own database connection (0: one per core)")
            ->capture_default_str()
            ->check(CLI::Range(0u, kMaxThreads));
        return [o] {
            o->fleet.rul.seed = o->record.rul.seed;
            const auto start = std::chrono::steady_clock::now();
            const fs::path out(o->out);
            check_replaceable(out);
            const fs::path staging = fresh_sibling(out, "new");
            Totals totals;
            try {
                totals = write_site(*o, staging);
                sync_site(staging);
                std::error_code ec;
                if (fs::exists(fs::symlink_status(out, ec))) {
                    check_replaceable(out);  // again: nothing foreign appeared meanwhile
                    const fs::path old = fresh_sibling(out, "old");
                    fs::rename(out, old);
                    fs::rename(staging, out);
                    fs::remove_all(old, ec);
                } else {
                    fs::rename(staging, out);
                }
            } catch (...) {
                std::error_code ec;
                fs::remove_all(staging, ec);
                throw;
            }
            const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            std::cerr << "site: wrote " << out.string() << "/ (index.html and " << totals.files - 1 << " tail pages, " << totals.lists << " session lists, " << totals.bytes
                      << " bytes) in " << std::fixed << std::setprecision(1) << s << " s\n";
            return 0;
        };
    }});

}  // namespace
}  // namespace emadiag::cli
