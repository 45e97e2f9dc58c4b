#include "measured/measured_import.hpp"

#include "emadiag/db/sha256.hpp"
#include "measured/cycle_detection.hpp"
#include "measured/derived_signals.hpp"
#include "measured/measured_error.hpp"
#include "measured/number_text.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <string_view>
#include <unordered_map>
#include <unordered_set>

namespace emadiag::measured {

namespace {


std::string_view trim(std::string_view f, char delimiter) {
    auto blank = [&](char c) { return (c == ' ' || c == '\t') && c != delimiter; };
    while (!f.empty() && blank(f.front())) f.remove_prefix(1);
    while (!f.empty() && blank(f.back())) f.remove_suffix(1);
    if (f.size() >= 2 && f.front() == '"' && f.back() == '"') f = f.substr(1, f.size() - 2);
    return f;
}

enum class NumberStatus { ok, malformed, out_of_range, not_finite };

NumberStatus parse_number(std::string_view f, char decimal, double& v) {
    if (!f.empty() && f.front() == '+') f.remove_prefix(1);
    if (f.empty()) return NumberStatus::malformed;
    char buf[128];
    if (decimal == ',') {
        if (f.size() > sizeof buf) return NumberStatus::malformed;
        for (std::size_t i = 0; i < f.size(); ++i) buf[i] = f[i] == ',' ? '.' : (f[i] == '.' ? ',' : f[i]);
        f = std::string_view(buf, f.size());
    }
    const auto r = std::from_chars(f.data(), f.data() + f.size(), v);
    if (r.ec == std::errc::result_out_of_range) return NumberStatus::out_of_range;
    if (r.ec != std::errc() || r.ptr != f.data() + f.size()) return NumberStatus::malformed;
    if (!std::isfinite(v)) return NumberStatus::not_finite;
    return NumberStatus::ok;
}

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};

/// What the importer does with one field of a row.
struct ColumnRole {
    int signal = -1;  ///< index into run.signals
    int label = -1;   ///< index into run.labels
    bool time = false;
    bool cycle = false;
    bool mapped = false;
};

/// One label column while reading: the last text and its index, so a repeated text costs a compare.
struct LabelState {
    std::unordered_map<std::string, std::uint32_t> index;
    std::string last;
    std::uint32_t last_index = 0;
    bool any = false;
};

class Importer {
public:
    Importer(std::string path, const ColumnMap& map) : path_(std::move(path)), map_(map) {}

    MeasuredRun run() {
        start_run();
        read_file();
        finish_rows();
        throw_if_problems();
        build_cycles_and_derived();
        return std::move(run_);
    }

private:
    void start_run();
    void read_file();
    void on_line(std::string_view line);
    void resolve_columns(const std::vector<std::string_view>& fields, bool from_header);
    void on_row(const std::vector<std::string_view>& fields);
    bool row_time(std::string_view field, bool new_cycle, double& t_s);
    bool row_cycle(std::string_view field, bool& new_cycle);
    void finish_rows();
    void build_cycles_and_derived();

    std::string where() const { return path_ + ":" + std::to_string(line_no_) + ": "; }
    std::string column_text(std::size_t index) const {
        if (index < header_.size()) return "column '" + header_[index] + "' (index " + std::to_string(index) + ")";
        return "column index " + std::to_string(index);
    }
    void problem(const std::string& text) {
        ++problem_count_;
        if (problems_.size() < kMeasuredMaxReportedProblems) problems_.push_back(text);
        if (problem_count_ >= kMeasuredMaxProblems) throw_if_problems();
    }
    [[noreturn]] void fatal(const std::string& text) {
        problem(text);
        throw_if_problems();
        throw MeasuredError(text);  // not reached
    }
    void throw_if_problems() const {
        if (problem_count_ == 0) return;
        std::string text = path_ + ": " + std::to_string(problem_count_) + " problem" + (problem_count_ == 1 ? "" : "s");
        if (problem_count_ > problems_.size()) text += " (the first " + std::to_string(problems_.size()) + " listed)";
        if (problem_count_ >= kMeasuredMaxProblems) text += "; reading stopped at the limit kMeasuredMaxProblems = " + std::to_string(kMeasuredMaxProblems);
        for (const std::string& p : problems_) text += "\n  " + p;
        throw MeasuredError(text);
    }

    std::string path_;
    const ColumnMap& map_;
    MeasuredRun run_;
    std::size_t line_no_ = 0;
    std::size_t file_bytes_ = 0;
    bool resolved_ = false;
    std::vector<std::string> header_;
    std::size_t header_line_ = 0;
    std::size_t ncols_ = 0;
    std::vector<ColumnRole> roles_;
    std::vector<std::string_view> fields_;
    std::vector<double> row_values_;
    std::vector<std::uint32_t> row_labels_;
    std::vector<LabelState> label_states_;
    std::size_t max_rows_ = 0;
    std::size_t values_per_row_ = 0;
    std::size_t problem_count_ = 0;
    std::vector<std::string> problems_;
    // time
    double nominal_period_s_ = 0.0;
    double prev_col_t_s_ = 0.0;
    std::size_t prev_line_ = 0;
    double cycle_abs0_s_ = 0.0, cycle_col0_s_ = 0.0, last_abs_s_ = 0.0;
    bool have_prev_time_ = false;
    // cycles from a column
    std::string cycle_key_;
    std::unordered_map<std::string, std::size_t> finished_cycles_;  // key -> its last line
    std::size_t time_col_ = 0, cycle_col_ = 0;
    std::size_t prev_row_line_ = 0;  // line of the previous data row
};

void Importer::start_run() {
    run_.source_path = path_;
    run_.map_path = map_.path;
    run_.map_sha256 = map_.sha256;
    run_.map_name = map_.name;
    for (const SignalColumn& s : map_.signals) {
        MeasuredSignal sig;
        sig.name = s.signal;
        sig.quantity = s.unit.quantity;
        if (s.noise) sig.noise_si = *s.noise * s.unit.factor;
        sig.origin = "column " + s.column.describe() + " (" + std::string(s.unit.name) + ", scale " + number_text(s.scale) + ", offset " +
                     number_text(s.offset) + ", sign " + (s.sign > 0 ? "+1" : "-1") + ")";
        run_.signals.push_back(std::move(sig));
    }
    for (const LabelColumnSpec& l : map_.labels) run_.labels.push_back({l.label, {}, {}});
    label_states_.resize(map_.labels.size());
    values_per_row_ = 1 + map_.signals.size() + map_.labels.size() + map_.derived.size();
    max_rows_ = kMeasuredMaxValues / values_per_row_;
    if (map_.time.rate_hz) nominal_period_s_ = 1.0 / *map_.time.rate_hz;
    row_values_.resize(map_.signals.size());
    row_labels_.resize(map_.labels.size());
}

void Importer::read_file() {
    // Opened without blocking and checked on the descriptor: a FIFO or a device is refused, never waited on.
    const int fd = ::open(path_.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) throw MeasuredError(path_ + ": cannot open: " + std::strerror(errno));
    struct stat st {};
    if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        ::close(fd);
        throw MeasuredError(path_ + ": not a regular file");
    }
    std::unique_ptr<std::FILE, FileCloser> f(::fdopen(fd, "rb"));
    if (!f) {
        ::close(fd);
        throw MeasuredError(path_ + ": cannot open: " + std::strerror(errno));
    }
    file_bytes_ = static_cast<std::size_t>(st.st_size);
    db::Sha256 hash;
    std::vector<char> block(kMeasuredReadBlockBytes + kMeasuredMaxLineBytes + 1);
    std::size_t carry = 0;  // bytes of an unfinished line at the start of `block`
    for (;;) {
        const std::size_t got = std::fread(block.data() + carry, 1, kMeasuredReadBlockBytes, f.get());
        if (got == 0) {
            if (std::ferror(f.get())) throw MeasuredError(path_ + ": read error after " + std::to_string(line_no_) + " lines");
            break;
        }
        hash.update(std::string_view(block.data() + carry, got));
        const char* p = block.data();
        const char* end = block.data() + carry + got;
        for (;;) {
            const char* nl = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)));
            if (nl == nullptr) break;
            on_line(std::string_view(p, static_cast<std::size_t>(nl - p)));
            p = nl + 1;
        }
        carry = static_cast<std::size_t>(end - p);
        if (carry > kMeasuredMaxLineBytes) {
            ++line_no_;
            fatal(where() + "line longer than the limit kMeasuredMaxLineBytes = " + std::to_string(kMeasuredMaxLineBytes) + " bytes");
        }
        std::memmove(block.data(), p, carry);
    }
    if (carry > 0) on_line(std::string_view(block.data(), carry));  // the last line has no line end
    run_.source_sha256 = hash.hex();
}

void Importer::on_line(std::string_view line) {
    ++line_no_;
    if (line.size() > kMeasuredMaxLineBytes) {
        fatal(where() + "line longer than the limit kMeasuredMaxLineBytes = " + std::to_string(kMeasuredMaxLineBytes) + " bytes");
    }
    if (line_no_ == 1 && line.starts_with("\xEF\xBB\xBF")) line.remove_prefix(3);  // a UTF-8 byte order mark
    if (line_no_ <= map_.format.skip_lines) return;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (!map_.format.comment_prefix.empty() && line.starts_with(map_.format.comment_prefix)) {
        ++run_.comment_lines;
        return;
    }
    if (line.empty()) {
        ++run_.blank_lines;
        return;
    }
    fields_.clear();
    const char delimiter = map_.format.delimiter;
    for (;;) {
        const void* d = std::memchr(line.data(), delimiter, line.size());
        if (d == nullptr) {
            fields_.push_back(trim(line, delimiter));
            break;
        }
        const std::size_t n = static_cast<std::size_t>(static_cast<const char*>(d) - line.data());
        fields_.push_back(trim(line.substr(0, n), delimiter));
        line.remove_prefix(n + 1);
        if (fields_.size() > kMeasuredMaxColumns) {
            fatal(where() + "more than the limit kMeasuredMaxColumns = " + std::to_string(kMeasuredMaxColumns) + " fields");
        }
    }
    if (!resolved_) {
        resolve_columns(fields_, map_.format.header);
        if (map_.format.header) return;
    }
    on_row(fields_);
}

void Importer::resolve_columns(const std::vector<std::string_view>& fields, bool from_header) {
    resolved_ = true;
    header_line_ = line_no_;
    ncols_ = fields.size();
    roles_.assign(ncols_, ColumnRole{});
    std::unordered_map<std::string, std::size_t> by_name;
    if (from_header) {
        for (std::size_t i = 0; i < fields.size(); ++i) {
            header_.emplace_back(fields[i]);
            if (!by_name.emplace(header_.back(), i).second) {
                problem(where() + "the header names column '" + header_.back() + "' twice (index " + std::to_string(by_name[header_.back()]) +
                        " and " + std::to_string(i) + ")");
            }
        }
    }
    auto find = [&](const ColumnRef& ref, const std::string& what) -> std::optional<std::size_t> {
        if (ref.index) {
            if (*ref.index < ncols_) return *ref.index;
            problem(where() + "column index " + std::to_string(*ref.index) + " (" + what + ") is beyond the " + std::to_string(ncols_) +
                    " columns of the file");
            return std::nullopt;
        }
        const auto it = by_name.find(*ref.name);
        if (it != by_name.end()) return it->second;
        std::string list;
        for (const std::string& h : header_) list += (list.empty() ? "" : ", ") + h;
        problem(where() + "column '" + *ref.name + "' (" + what + ") is not in the header (the header has: " + list + ")");
        return std::nullopt;
    };
    auto numeric = [&](std::size_t i, const std::string& what) {
        if (roles_[i].signal >= 0 || roles_[i].time) problem(where() + column_text(i) + " is mapped twice as a number (" + what + ")");
    };
    for (std::size_t k = 0; k < map_.signals.size(); ++k) {
        if (const auto i = find(map_.signals[k].column, "signal '" + map_.signals[k].signal + "'")) {
            numeric(*i, "signal '" + map_.signals[k].signal + "'");
            roles_[*i].signal = static_cast<int>(k);
            roles_[*i].mapped = true;
        }
    }
    for (std::size_t k = 0; k < map_.labels.size(); ++k) {
        if (const auto i = find(map_.labels[k].column, "label '" + map_.labels[k].label + "'")) {
            roles_[*i].label = static_cast<int>(k);
            roles_[*i].mapped = true;
        }
    }
    if (map_.time.source == TimeSource::column) {
        if (const auto i = find(map_.time.column, "the time")) {
            numeric(*i, "the time");
            roles_[*i].time = true;
            roles_[*i].mapped = true;
            time_col_ = *i;
        }
    }
    if (map_.cycles.source == CycleSource::column) {
        if (const auto i = find(map_.cycles.column, "the cycles")) {
            roles_[*i].cycle = true;
            roles_[*i].mapped = true;
            cycle_col_ = *i;
        }
    }
    for (const ColumnRef& ref : map_.ignored) {
        if (const auto i = find(ref, "ignored")) roles_[*i].mapped = true;
    }
    for (std::size_t i = 0; i < ncols_ && !map_.ignore_unmapped; ++i) {
        if (!roles_[i].mapped) {
            problem(where() + column_text(i) + " is not in the map (map it, list it with \"ignore\": true, or set \"unmapped_columns\": \"ignore\")");
        }
    }
    throw_if_problems();
    // Reserve for the rows the file can hold at this line's length: no doubling past the need.
    const std::size_t line_bytes = std::max<std::size_t>(1, [&] {
        std::size_t b = 0;
        for (std::string_view f : fields) b += f.size() + 1;
        return b;
    }());
    const std::size_t expect = std::min(max_rows_, file_bytes_ / line_bytes + 16);
    run_.time_s.reserve(expect);
    for (MeasuredSignal& s : run_.signals) s.values.reserve(expect);
    for (LabelColumn& l : run_.labels) l.row_value.reserve(expect);
}

bool Importer::row_cycle(std::string_view field, bool& new_cycle) {
    new_cycle = false;
    const std::size_t row = run_.time_s.size();
    if (row == 0 && run_.cycles.empty()) {
        cycle_key_.assign(field);
        run_.cycles.push_back({0, 0, cycle_key_, line_no_});
        new_cycle = true;
        return true;
    }
    if (field == cycle_key_) return true;
    const auto seen = finished_cycles_.find(std::string(field));
    if (seen != finished_cycles_.end()) {
        problem(where() + column_text(cycle_col_) + ": cycle '" + std::string(field) + "' starts again; it ended at line " +
                std::to_string(seen->second) + " (a cycle's rows must be contiguous)");
        return false;
    }
    finished_cycles_.emplace(cycle_key_, prev_row_line_);
    run_.cycles.back().end = row;
    cycle_key_.assign(field);
    run_.cycles.push_back({row, row, cycle_key_, line_no_});
    new_cycle = true;
    return true;
}

bool Importer::row_time(std::string_view field, bool new_cycle, double& t_s) {
    const TimeSpec& ts = map_.time;
    if (ts.source == TimeSource::rate) {
        t_s = static_cast<double>(run_.time_s.size()) * nominal_period_s_;
        return true;
    }
    double raw = 0.0;
    const NumberStatus status = parse_number(field, map_.format.decimal, raw);
    auto at = [&] { return where() + column_text(time_col_) + ": '" + std::string(field) + "'"; };  // built on a problem only
    if (status == NumberStatus::malformed) return problem(at() + " is not a number"), false;
    if (status == NumberStatus::out_of_range) return problem(at() + " is out of the range of a double"), false;
    if (status == NumberStatus::not_finite) return problem(at() + " is not finite (NaN and infinity are refused)"), false;
    const double col_s = ts.unit.factor * raw + ts.unit.offset;
    const bool restart = ts.restarts_per_cycle && new_cycle;
    if (!have_prev_time_ || restart) {
        cycle_abs0_s_ = have_prev_time_ ? last_abs_s_ + nominal_period_s_ : col_s;
        cycle_col0_s_ = col_s;
    } else {
        const double step_s = col_s - prev_col_t_s_;
        auto prev = [&] { return " the previous time " + number_text(prev_col_t_s_) + " s at line " + std::to_string(prev_line_); };
        if (!(step_s > 0.0)) {
            problem(at() + " (" + number_text(col_s) + " s) is not after" + prev() + " (time must increase)");
            prev_col_t_s_ = col_s;
            prev_line_ = line_no_;
            return false;
        }
        if (nominal_period_s_ == 0.0) nominal_period_s_ = step_s;  // no rate_hz: the first step is nominal
        const double limit_s = ts.max_step_factor * nominal_period_s_;
        if (step_s > limit_s) {
            problem(at() + " (" + number_text(col_s) + " s) is " + number_text(step_s) + " s after" + prev() + ": a gap (the limit is max_step_factor " +
                    number_text(ts.max_step_factor) + " x the nominal period " + number_text(nominal_period_s_) + " s = " + number_text(limit_s) + " s)");
        }
    }
    prev_col_t_s_ = col_s;
    prev_line_ = line_no_;
    have_prev_time_ = true;
    t_s = cycle_abs0_s_ + (col_s - cycle_col0_s_);
    last_abs_s_ = t_s;
    return true;
}

void Importer::on_row(const std::vector<std::string_view>& fields) {
    if (fields.size() != ncols_) {
        problem(where() + std::to_string(fields.size()) + " fields where " +
                (map_.format.header ? "the header has " : "line " + std::to_string(header_line_) + " has ") + std::to_string(ncols_) +
                " (a ragged row)");
        return;
    }
    if (run_.time_s.size() >= max_rows_) {
        fatal(where() + "more than " + std::to_string(max_rows_) + " rows: the limit kMeasuredMaxValues = " + std::to_string(kMeasuredMaxValues) +
              " values held (" + std::to_string(values_per_row_) + " per row)");
    }
    bool ok = true, new_cycle = false;
    if (map_.cycles.source == CycleSource::column) ok = row_cycle(fields[cycle_col_], new_cycle);
    struct LineMark {
        std::size_t& mark;
        std::size_t line;
        ~LineMark() { mark = line; }
    } mark_line{prev_row_line_, line_no_};
    double t_s = 0.0;
    if (!row_time(map_.time.source == TimeSource::column ? fields[time_col_] : std::string_view(), new_cycle, t_s)) ok = false;
    for (std::size_t i = 0; i < ncols_; ++i) {
        const ColumnRole& role = roles_[i];
        if (role.signal >= 0) {
            const SignalColumn& sc = map_.signals[static_cast<std::size_t>(role.signal)];
            double raw = 0.0;
            const NumberStatus status = parse_number(fields[i], map_.format.decimal, raw);
            if (status != NumberStatus::ok) {
                const std::string at = where() + column_text(i) + ": '" + std::string(fields[i]) + "'";
                if (status == NumberStatus::malformed) problem(at + " is not a number");
                else if (status == NumberStatus::out_of_range) problem(at + " is out of the range of a double");
                else problem(at + " is not finite (NaN and infinity are refused)");
                ok = false;
                continue;
            }
            // docs/column-map.md: value in the unit = sign * (scale * raw + offset); SI = factor * value + unit offset.
            row_values_[static_cast<std::size_t>(role.signal)] = sc.unit.factor * (sc.sign * (sc.scale * raw + sc.offset)) + sc.unit.offset;
        }
        if (role.label >= 0) {
            const std::size_t k = static_cast<std::size_t>(role.label);
            LabelState& st = label_states_[k];
            if (!st.any || fields[i] != st.last) {
                st.last.assign(fields[i]);
                auto it = st.index.find(st.last);
                if (it == st.index.end()) {
                    if (st.index.size() >= kMeasuredMaxLabelValues) {
                        fatal(where() + column_text(i) + ": '" + st.last + "' would be distinct text number " + std::to_string(st.index.size() + 1) +
                              " of label '" + map_.labels[k].label + "': the limit kMeasuredMaxLabelValues = " +
                              std::to_string(kMeasuredMaxLabelValues));
                    }
                    it = st.index.emplace(st.last, static_cast<std::uint32_t>(run_.labels[k].values.size())).first;
                    run_.labels[k].values.push_back(st.last);
                }
                st.last_index = it->second;
                st.any = true;
            }
            row_labels_[k] = st.last_index;
        }
    }
    if (!ok || problem_count_ > 0) return;  // a file with problems is refused: its rows are not kept
    run_.time_s.push_back(t_s);
    for (std::size_t k = 0; k < row_values_.size(); ++k) run_.signals[k].values.push_back(row_values_[k]);
    for (std::size_t k = 0; k < row_labels_.size(); ++k) run_.labels[k].row_value.push_back(row_labels_[k]);
}

void Importer::finish_rows() {
    if (!resolved_) fatal(path_ + ": no " + (map_.format.header ? "header" : "data") + " line after " + std::to_string(line_no_) + " lines");
    if (problem_count_ == 0 && run_.time_s.empty()) fatal(path_ + ": no data rows after the header at line " + std::to_string(header_line_));
    if (!run_.cycles.empty()) run_.cycles.back().end = run_.time_s.size();
    if (nominal_period_s_ == 0.0) {
        // One row from a time column: no step, no nominal period.
        nominal_period_s_ = run_.time_s.size() > 1 ? run_.time_s[1] - run_.time_s[0] : 0.0;
    }
    run_.nominal_period_s = nominal_period_s_;
}

void Importer::build_cycles_and_derived() {
    auto motion_now = [&]() {
        if (map_.cycles.source != CycleSource::motion || !run_.cycles.empty()) return;
        const MeasuredSignal* s = run_.signal(map_.cycles.signal);
        if (s == nullptr) return;
        run_.cycles = detect_motion_cycles(run_.time_s, s->values, map_.cycles);
    };
    motion_now();
    for (const DerivedSpec& d : map_.derived) {
        run_.signals.push_back(derive_signal(run_, d, map_.path));
        motion_now();
    }
    std::size_t covered = 0;
    for (const Cycle& c : run_.cycles) covered += c.end - c.begin;
    run_.rows_outside_cycles = run_.time_s.size() - covered;
}

}  // namespace

MeasuredRun import_measured_csv(const std::string& csv_path, const ColumnMap& map) {
    Importer importer(csv_path, map);
    return importer.run();
}

}  // namespace emadiag::measured
