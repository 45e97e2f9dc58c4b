#include "core/run_csv.hpp"
#include "emadiag/io/bounded_line.hpp"

#include "core/emadiag_error.hpp"
#include "core/run_validity.hpp"
#include "emadiag/io/output_path.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string_view>

namespace emadiag {
namespace {

constexpr std::size_t kMaxReportedProblems = 50;


std::vector<std::string> split(const std::string& line, char sep) {
    std::vector<std::string> out;
    std::string cur;
    for (char ch : line) {
        if (ch == sep) {
            out.push_back(cur);
            cur.clear();
        } else if (ch != '\r') {
            cur += ch;
        }
    }
    out.push_back(cur);
    return out;
}

std::string trim(const std::string& s) {
    const auto b = s.find_first_not_of(" \t\r");
    if (b == std::string::npos) return {};
    const auto e = s.find_last_not_of(" \t\r");
    return s.substr(b, e - b + 1);
}

bool parse_double(const std::string& text, double& out) {
    const std::string t = trim(text);
    if (t.empty()) return false;
    const char* first = t.data();
    const char* last = t.data() + t.size();
    if (*first == '+') ++first;
    auto [ptr, ec] = std::from_chars(first, last, out);
    return ec == std::errc() && ptr == last;
}

/// The problems of one file, each "NAME:LINE: message", the first kMaxReportedProblems kept.
struct CsvProblems {
    const std::string& name;
    std::vector<std::string> list;
    void operator()(std::size_t line, const std::string& msg) {
        if (list.size() < kMaxReportedProblems) list.push_back(name + ":" + std::to_string(line) + ": " + msg);
    }
};

/// The encoding, from the first bytes: a UTF-8 byte order mark is skipped (the text after it is the
/// same); UTF-16 (a spreadsheet's "Unicode text") is refused with the fix.
void check_first_line_encoding(std::string& line, const std::string& name) {
    static constexpr std::string_view kUtf8Bom = "\xEF\xBB\xBF";
    if (line.rfind(kUtf8Bom, 0) == 0) line.erase(0, kUtf8Bom.size());
    const bool utf16_bom = line.rfind("\xFF\xFE", 0) == 0 || line.rfind("\xFE\xFF", 0) == 0;
    if (utf16_bom || line.find('\0') != std::string::npos) {
        throw EmadiagError("invalid run CSV: " + name + ": line 1 " +
                           (utf16_bom ? "starts with a UTF-16 byte order mark" : "holds NUL bytes") +
                           ": the file looks UTF-16 encoded; save it as UTF-8 or ASCII text (e.g. iconv -f UTF-16 -t UTF-8)");
    }
}

/// The run's constants, case and sequence from its metadata (read before), each missing or bad value
/// a problem at the line that set it.
void read_required_metadata(Run& run, const std::vector<std::pair<std::string, std::size_t>>& meta_line, CsvProblems& problem) {
    const auto line_of = [&](const std::string& key) -> std::size_t {
        for (const auto& [k, l] : meta_line)
            if (k == key) return l;
        return 1;
    };
    auto need = [&](const char* key, double& dst, bool positive) {
        const auto v = run.meta_value(key);
        if (!v) {
            problem(1, std::string("missing metadata key '") + key + "'");
            return;
        }
        double x;
        if (!parse_double(*v, x) || !std::isfinite(x) || (positive && !(x > 0))) {
            problem(line_of(key), std::string("metadata ") + key + "=" + *v + " is not a positive number");
            return;
        }
        dst = x;
    };
    need("k_t_Nm_per_A", run.constants.k_t_nm_per_a, true);
    need("J_kgm2", run.constants.j_kgm2, true);
    need("tau", run.constants.tau, true);
    need("sample_period_s", run.constants.sample_period_s, true);
    // The one parser of each (a value it refuses is a problem reported above, with its line).
    if (auto c = run.meta_value("case")) {
        if (!metadata_value_problem("case", *c)) run.load_case = sim::parse_load_case(*c);
    } else {
        problem(1, "missing metadata key 'case'");
    }
    if (auto s = run.meta_value("sequence")) {
        if (!metadata_value_problem("sequence", *s)) run.sequence = sim::parse_sequence(*s);
    } else {
        problem(1, "missing metadata key 'sequence'");
    }
}

}  // namespace

void write_run_csv(std::ostream& out, const Run& run) {
    Run copy_meta;  // the metadata only, with the required keys from the run's fields
    copy_meta.meta = run.meta;
    copy_meta.constants = run.constants;
    copy_meta.load_case = run.load_case;
    copy_meta.sequence = run.sequence;
    copy_meta.set_required_meta();
    for (const auto& [k, v] : copy_meta.meta) out << "# " << k << '=' << v << '\n';
    out << "t_s,current_A,speed_rad_s,theta_m_rad,hinge_moment_Nm,command_deg";
    for (const auto& col : run.extra_columns) out << ',' << col.first;
    out << '\n';
    for (std::size_t i = 0; i < run.samples.size(); ++i) {
        const RunSample& s = run.samples[i];
        out << format_exact(s.t_s) << ',' << format_exact(s.current_a) << ',' << format_exact(s.speed_rad_s) << ',' << format_exact(s.theta_m_rad) << ','
            << format_exact(s.hinge_moment_nm) << ',' << format_exact(s.command_deg);
        for (const auto& col : run.extra_columns) out << ',' << format_exact(col.second.at(i));
        out << '\n';
    }
}

void write_run_csv_file(const std::string& path, const Run& run, const io::OutputInputs& inputs) {
    // A unique temporary file renamed into place: a failed write never leaves a truncated run behind.
    io::write_output_file<EmadiagError>(path, "run CSV", inputs, [&run](std::ostream& out) { write_run_csv(out, run); });
}

Run read_run_csv(std::istream& in, const std::string& name) {
    Run run;
    CsvProblems problem{name, {}};
    std::string line;
    std::size_t line_no = 0;
    std::vector<std::string> header;
    std::size_t header_line = 0;
    std::size_t meta_lines = 0, bad_rows = 0;
    std::vector<std::pair<std::string, std::size_t>> meta_line;  // key -> the file line that set it
    bool too_long = false;
    while (io::read_bounded_line(in, line, kCsvMaxLineBytes, too_long)) {
        ++line_no;
        if (line_no == 1) check_first_line_encoding(line, name);
        if (too_long) {
            problem(line_no, "line longer than the limit kCsvMaxLineBytes = " + std::to_string(kCsvMaxLineBytes) + " bytes");
            if (++bad_rows > kCsvMaxBadRows) break;
            continue;
        }
        if (line.empty() || line == "\r") continue;
        if (line[0] == '#') {
            if (!header.empty()) {
                problem(line_no, "metadata line after the header row");
                if (++bad_rows > kCsvMaxBadRows) break;
                continue;
            }
            if (++meta_lines > kCsvMaxMetaLines) {
                problem(line_no, "more than the limit kCsvMaxMetaLines = " + std::to_string(kCsvMaxMetaLines) + " metadata lines");
                break;
            }
            const std::string body = trim(line.substr(1));
            const auto eq = body.find('=');
            if (eq == std::string::npos) {
                problem(line_no, "metadata line without '=': expected '# key=value'");
                continue;
            }
            const std::string key = trim(body.substr(0, eq));
            if (run.meta_value(key)) problem(line_no, "duplicate metadata key '" + key + "'");
            const std::string value = trim(body.substr(eq + 1));
            if (const auto bad = metadata_value_problem(key, value)) problem(line_no, "metadata " + *bad);
            run.set_meta(key, value);
            meta_line.emplace_back(key, line_no);
            continue;
        }
        if (header.empty()) {
            header = split(line, ',');
            header_line = line_no;
            for (auto& h : header) h = trim(h);
            if (header.size() > kCsvMaxColumns) {
                problem(line_no, std::to_string(header.size()) + " columns exceed the limit kCsvMaxColumns = " +
                                     std::to_string(kCsvMaxColumns));
                break;
            }
            for (std::size_t c = 0; c < std::size(kCsvRequiredColumns); ++c) {
                if (c >= header.size() || header[c] != kCsvRequiredColumns[c]) {
                    problem(line_no, "header column " + std::to_string(c + 1) + " must be '" + kCsvRequiredColumns[c] +
                                         "', found '" + (c < header.size() ? header[c] : std::string("<missing>")) + "'");
                }
            }
            for (std::size_t c = std::size(kCsvRequiredColumns); c < header.size(); ++c) {
                run.extra_columns.emplace_back(header[c], std::vector<double>{});
            }
            continue;
        }
        if ((run.samples.size() + 1) * header.size() > kCsvMaxValues) {
            problem(line_no, "more than " + std::to_string(run.samples.size()) + " rows of " + std::to_string(header.size()) +
                                 " columns: the limit kCsvMaxValues = " + std::to_string(kCsvMaxValues) + " numbers per run");
            break;
        }
        const auto cells = split(line, ',');
        if (cells.size() != header.size()) {
            problem(line_no, "expected " + std::to_string(header.size()) + " columns, found " + std::to_string(cells.size()));
            if (++bad_rows > kCsvMaxBadRows) break;
            continue;
        }
        double v[6];
        bool ok = true;
        for (std::size_t c = 0; c < cells.size(); ++c) {
            double x;
            if (!parse_double(cells[c], x) || !std::isfinite(x)) {
                problem(line_no, "column '" + header[c] + "': '" + cells[c].substr(0, 40) + "' is not a finite number");
                ok = false;
                continue;
            }
            if (const auto impossible = sample_value_problem(header[c], x)) {
                problem(line_no, "column '" + header[c] + "': " + *impossible);
                ok = false;
                continue;
            }
            if (c < 6) {
                v[c] = x;
            } else {
                run.extra_columns[c - 6].second.push_back(x);
            }
        }
        if (!ok) {
            // Extra columns parsed before the bad cell are dropped with the row, keeping them aligned.
            for (auto& col : run.extra_columns) col.second.resize(run.samples.size());
            if (++bad_rows > kCsvMaxBadRows) break;
            continue;
        }
        run.samples.push_back(RunSample{v[0], v[1], v[2], v[3], v[4], v[5]});
    }
    if (header.empty()) problem(line_no, "no header row (expected t_s,current_A,...)");
    (void)header_line;
    read_required_metadata(run, meta_line, problem);
    if (!problem.list.empty()) {
        std::string msg = "invalid run CSV:";
        for (const auto& p : problem.list) msg += "\n  " + p;
        throw EmadiagError(msg);
    }
    return run;
}

Run read_run_csv_file(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw EmadiagError("cannot open run file " + path);
    return read_run_csv(in, path);
}

}  // namespace emadiag
