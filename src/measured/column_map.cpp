#include "measured/column_map.hpp"

#include "emadiag/db/sha256.hpp"
#include "emadiag/io/bounded_json.hpp"
#include "measured/measured_error.hpp"

#include <cmath>
#include <set>
#include <utility>

namespace emadiag::measured {

using nlohmann::json;

std::string ColumnRef::describe() const {
    if (name) return "'" + *name + "'";
    if (index) return "index " + std::to_string(*index);
    return "(none)";
}

namespace {

/// Problems found in one map, each "SOURCE: /path: message"; thrown together at the end.
class MapReader {
public:
    explicit MapReader(std::string source) : source_(std::move(source)) {}

    void problem(const std::string& path, const std::string& message) { problems_.push_back(source_ + ": " + path + ": " + message); }

    void throw_if_any() const {
        if (problems_.empty()) return;
        std::string text = "column map " + source_ + ": " + std::to_string(problems_.size()) + " problem" +
                           (problems_.size() == 1 ? "" : "s");
        for (const std::string& p : problems_) text += "\n  " + p;
        throw MeasuredError(text);
    }

    /// Keys of `obj` outside `allowed` are problems (a misspelt key would otherwise be ignored).
    void only_keys(const json& obj, const std::string& path, std::initializer_list<const char*> allowed) {
        io::for_each_unknown_key(obj, allowed, [&](const std::string& key, const std::string& known) {
            problem(path + "/" + key, "unknown key (known here: " + known + ")");
        });
    }

    std::optional<std::string> string_at(const json& obj, const std::string& path, const char* key, bool required) {
        const auto it = obj.find(key);
        if (it == obj.end()) {
            if (required) problem(path + "/" + key, "missing");
            return std::nullopt;
        }
        if (!it->is_string()) {
            problem(path + "/" + key, "must be a string, not " + it->dump());
            return std::nullopt;
        }
        return it->get<std::string>();
    }

    std::optional<double> number_at(const json& obj, const std::string& path, const char* key, bool required) {
        const auto it = obj.find(key);
        if (it == obj.end()) {
            if (required) problem(path + "/" + key, "missing");
            return std::nullopt;
        }
        if (!it->is_number() || !std::isfinite(it->get<double>())) {
            problem(path + "/" + key, "must be a finite number, not " + it->dump());
            return std::nullopt;
        }
        return it->get<double>();
    }

    std::optional<bool> bool_at(const json& obj, const std::string& path, const char* key) {
        const auto it = obj.find(key);
        if (it == obj.end()) return std::nullopt;
        if (!it->is_boolean()) {
            problem(path + "/" + key, "must be true or false, not " + it->dump());
            return std::nullopt;
        }
        return it->get<bool>();
    }

    /// {"column": "name"} or {"index": N}: exactly one of the two.
    ColumnRef column_ref(const json& obj, const std::string& path) {
        ColumnRef ref;
        const bool has_name = obj.contains("column"), has_index = obj.contains("index");
        if (has_name == has_index) {
            problem(path, "give exactly one of \"column\" (a header name) and \"index\" (0-based)");
            return ref;
        }
        if (has_name) {
            ref.name = string_at(obj, path, "column", true);
            if (ref.name && ref.name->empty()) problem(path + "/column", "must not be empty");
        } else {
            const json& i = obj.at("index");
            if (!i.is_number_unsigned()) problem(path + "/index", "must be a column number from 0, not " + i.dump());
            else ref.index = i.get<std::size_t>();
        }
        return ref;
    }

    std::optional<Unit> unit_at(const json& obj, const std::string& path, const char* key, bool required) {
        const auto name = string_at(obj, path, key, required);
        if (!name) return std::nullopt;
        const auto unit = find_unit(*name);
        if (!unit) problem(path + "/" + key, "unknown unit '" + *name + "' (known units: " + known_units_text() + ")");
        return unit;
    }

    /// A signal or label name: [a-z][a-z0-9_]*, at most kMaxSignalNameChars.
    bool check_name(const std::string& name, const std::string& path) {
        bool ok = !name.empty() && name.size() <= kMaxSignalNameChars && name[0] >= 'a' && name[0] <= 'z';
        for (char c : name) ok = ok && ((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_');
        if (!ok) {
            problem(path, "name '" + name + "' must be a lowercase letter then letters, digits or '_', at most " +
                              std::to_string(kMaxSignalNameChars) + " characters");
        }
        return ok;
    }

    /// The objects of the array `key` (at most kMaxMapEntries), each with its path; problems for
    /// anything else. `required`: the array must be there and not empty.
    std::vector<std::pair<std::string, const json*>> entries(const json& root, const char* key, bool required) {
        std::vector<std::pair<std::string, const json*>> out;
        const std::string path = std::string("/") + key;
        const auto it = root.find(key);
        if (it == root.end() && !required) return out;
        if (it == root.end() || !it->is_array() || (required && it->empty())) {
            problem(path, required ? "must be a non-empty array" : "must be an array");
            return out;
        }
        if (it->size() > kMaxMapEntries) problem(path, std::to_string(it->size()) + " entries exceed the limit kMaxMapEntries = " + std::to_string(kMaxMapEntries));
        for (std::size_t i = 0; i < it->size() && i < kMaxMapEntries; ++i) {
            const json& e = (*it)[i];
            if (e.is_object()) out.emplace_back(path + "/" + std::to_string(i), &e);
            else problem(path + "/" + std::to_string(i), "must be an object");
        }
        return out;
    }

private:
    std::string source_;
    std::vector<std::string> problems_;
};

void read_format(MapReader& r, const json& root, CsvFormat& f) {
    const auto it = root.find("format");
    if (it == root.end()) return;
    if (!it->is_object()) {
        r.problem("/format", "must be an object");
        return;
    }
    const json& o = *it;
    r.only_keys(o, "/format", {"delimiter", "decimal", "skip_lines", "header", "comment_prefix"});
    if (const auto d = r.string_at(o, "/format", "delimiter", false)) {
        const std::string v = *d == "\\t" ? "\t" : *d;
        if (v.size() != 1 || v[0] == '"' || v[0] == '\n' || v[0] == '\r') r.problem("/format/delimiter", "must be one character other than a quote or a line end, not '" + *d + "'");
        else f.delimiter = v[0];
    }
    if (const auto d = r.string_at(o, "/format", "decimal", false)) {
        if (*d != "." && *d != ",") r.problem("/format/decimal", "must be \".\" or \",\", not '" + *d + "'");
        else f.decimal = (*d)[0];
    }
    if (f.delimiter == f.decimal) r.problem("/format", "the delimiter and the decimal mark are both '" + std::string(1, f.delimiter) + "'");
    if (o.contains("skip_lines")) {
        if (!o.at("skip_lines").is_number_unsigned()) r.problem("/format/skip_lines", "must be a count from 0, not " + o.at("skip_lines").dump());
        else f.skip_lines = o.at("skip_lines").get<std::size_t>();
    }
    if (const auto h = r.bool_at(o, "/format", "header")) f.header = *h;
    if (const auto c = r.string_at(o, "/format", "comment_prefix", false)) f.comment_prefix = *c;
}

void read_columns(MapReader& r, const json& root, ColumnMap& m, std::set<std::string>& names) {
    for (const auto& [path, entry] : r.entries(root, "columns", true)) {
        const json& c = *entry;
        r.only_keys(c, path, {"column", "index", "signal", "label", "ignore", "unit", "quantity", "scale", "offset", "sign", "noise"});
        const ColumnRef ref = r.column_ref(c, path);
        const int roles = int(c.contains("signal")) + int(c.contains("label")) + int(c.contains("ignore"));
        if (roles != 1) {
            r.problem(path, "give exactly one of \"signal\", \"label\" and \"ignore\"");
            continue;
        }
        if (c.contains("ignore")) {
            if (c.at("ignore") != true) r.problem(path + "/ignore", "must be true");
            m.ignored.push_back(ref);
            continue;
        }
        if (c.contains("label")) {
            const auto label = r.string_at(c, path, "label", true);
            for (const char* k : {"unit", "quantity", "scale", "offset", "sign", "noise"}) {
                if (c.contains(k)) r.problem(path + "/" + k, "a label column is text: it has no " + std::string(k));
            }
            if (label && r.check_name(*label, path + "/label")) {
                if (!names.insert(*label).second) r.problem(path + "/label", "'" + *label + "' is named twice");
                m.labels.push_back({ref, *label});
            }
            continue;
        }
        SignalColumn s;
        s.column = ref;
        const auto signal = r.string_at(c, path, "signal", true);
        const auto unit = r.unit_at(c, path, "unit", true);
        if (const auto q = r.string_at(c, path, "quantity", false); q && unit) {
            const auto quantity = parse_quantity(*q);
            if (!quantity) r.problem(path + "/quantity", "unknown quantity '" + *q + "'");
            else if (*quantity != unit->quantity) {
                r.problem(path + "/unit", "unit '" + std::string(unit->name) + "' is a " + std::string(quantity_name(unit->quantity)) +
                                              ", not a " + *q);
            }
        }
        s.scale = r.number_at(c, path, "scale", false).value_or(1.0);
        if (s.scale == 0.0) r.problem(path + "/scale", "must not be 0");
        s.offset = r.number_at(c, path, "offset", false).value_or(0.0);
        s.sign = r.number_at(c, path, "sign", false).value_or(1.0);
        if (s.sign != 1.0 && s.sign != -1.0) r.problem(path + "/sign", "must be 1 or -1, not " + c.at("sign").dump());
        s.noise = r.number_at(c, path, "noise", false);
        if (s.noise && *s.noise < 0.0) r.problem(path + "/noise", "a standard deviation must be >= 0, not " + c.at("noise").dump());
        if (signal && r.check_name(*signal, path + "/signal")) {
            if (*signal == "time") r.problem(path + "/signal", "'time' is the run's time axis: give it in \"time\"");
            else if (!names.insert(*signal).second) r.problem(path + "/signal", "'" + *signal + "' is named twice");
        }
        if (signal && unit) {
            s.signal = *signal;
            s.unit = *unit;
            m.signals.push_back(s);
        }
    }
}

void read_time(MapReader& r, const json& root, TimeSpec& t) {
    const auto it = root.find("time");
    if (it == root.end() || !it->is_object()) {
        r.problem("/time", "must be an object: {\"source\": \"rate\", \"rate_hz\": F} or {\"source\": \"column\", \"column\": NAME, \"unit\": U}");
        return;
    }
    const json& o = *it;
    r.only_keys(o, "/time", {"source", "rate_hz", "column", "index", "unit", "restarts_per_cycle", "max_step_factor"});
    const auto source = r.string_at(o, "/time", "source", true);
    t.rate_hz = r.number_at(o, "/time", "rate_hz", false);
    if (t.rate_hz && *t.rate_hz <= 0.0) r.problem("/time/rate_hz", "must be > 0, not " + o.at("rate_hz").dump());
    t.max_step_factor = r.number_at(o, "/time", "max_step_factor", false).value_or(kDefaultMaxStepFactor);
    if (t.max_step_factor <= 1.0) r.problem("/time/max_step_factor", "must be > 1 (a step of one period is never a gap), not " + o.at("max_step_factor").dump());
    t.restarts_per_cycle = r.bool_at(o, "/time", "restarts_per_cycle").value_or(false);
    if (!source) return;
    if (*source == "rate") {
        t.source = TimeSource::rate;
        if (!t.rate_hz) r.problem("/time/rate_hz", "missing: the time from a rate needs rate_hz");
        for (const char* k : {"column", "index", "unit", "restarts_per_cycle", "max_step_factor"}) {
            if (o.contains(k)) r.problem(std::string("/time/") + k, "only for the time from a column");
        }
    } else if (*source == "column") {
        t.source = TimeSource::column;
        t.column = r.column_ref(o, "/time");
        if (const auto u = r.unit_at(o, "/time", "unit", true)) {
            if (u->quantity != Quantity::time) r.problem("/time/unit", "'" + std::string(u->name) + "' is not a unit of time");
            else t.unit = *u;
        }
    } else {
        r.problem("/time/source", "must be \"rate\" or \"column\", not '" + *source + "'");
    }
}

void read_cycles(MapReader& r, const json& root, CycleSpec& c) {
    const auto it = root.find("cycles");
    if (it == root.end()) return;
    if (!it->is_object()) {
        r.problem("/cycles", "must be an object");
        return;
    }
    const json& o = *it;
    r.only_keys(o, "/cycles", {"source", "column", "index", "signal", "speed_threshold", "min_rest_s", "direction"});
    const auto source = r.string_at(o, "/cycles", "source", true);
    if (!source) return;
    if (*source == "none") {
        c.source = CycleSource::none;
    } else if (*source == "column") {
        c.source = CycleSource::column;
        c.column = r.column_ref(o, "/cycles");
    } else if (*source == "motion") {
        c.source = CycleSource::motion;
        c.signal = r.string_at(o, "/cycles", "signal", true).value_or("");
        c.speed_threshold_si = r.number_at(o, "/cycles", "speed_threshold", true).value_or(0.0);
        if (o.contains("speed_threshold") && c.speed_threshold_si <= 0.0) r.problem("/cycles/speed_threshold", "must be > 0, not " + o.at("speed_threshold").dump());
        c.min_rest_s = r.number_at(o, "/cycles", "min_rest_s", true).value_or(0.0);
        if (c.min_rest_s < 0.0) r.problem("/cycles/min_rest_s", "must be >= 0, not " + o.at("min_rest_s").dump());
        const std::string d = r.string_at(o, "/cycles", "direction", false).value_or("any");
        if (d == "positive") c.direction = MotionDirection::positive;
        else if (d == "negative") c.direction = MotionDirection::negative;
        else if (d == "any") c.direction = MotionDirection::any;
        else r.problem("/cycles/direction", "must be \"positive\", \"negative\" or \"any\", not '" + d + "'");
    } else {
        r.problem("/cycles/source", "must be \"none\", \"column\" or \"motion\", not '" + *source + "'");
    }
}

void read_derived(MapReader& r, const json& root, ColumnMap& m, std::set<std::string>& names) {
    for (const auto& [path, entry] : r.entries(root, "derived", false)) {
        const json& o = *entry;
        r.only_keys(o, path, {"signal", "op", "of", "method", "half_window", "per_cycle"});
        DerivedSpec d;
        const auto signal = r.string_at(o, path, "signal", true);
        const auto op = r.string_at(o, path, "op", true);
        std::size_t operands = 2;
        if (op && *op == "difference") d.op = DerivedOp::difference;
        else if (op && *op == "sum") d.op = DerivedOp::sum;
        else if (op && *op == "derivative") {
            d.op = DerivedOp::derivative;
            operands = 1;
        } else if (op) r.problem(path + "/op", "must be \"difference\", \"sum\" or \"derivative\", not '" + *op + "'");
        const auto of = o.find("of");
        if (of != o.end() && of->is_string() && operands == 1) d.of.push_back(of->get<std::string>());
        else if (of != o.end() && of->is_array() && of->size() == operands) {
            for (const json& n : *of) {
                if (n.is_string()) d.of.push_back(n.get<std::string>());
            }
        }
        if (d.of.size() != operands) r.problem(path + "/of", operands == 1 ? "must name one signal" : "must be an array of two signal names");
        for (std::size_t k = 0; k < d.of.size(); ++k) {
            if (!names.contains(d.of[k])) r.problem(path + "/of", "'" + d.of[k] + "' is not a signal defined above it");
        }
        if (const auto method = r.string_at(o, path, "method", d.op == DerivedOp::derivative)) {
            if (d.op != DerivedOp::derivative) r.problem(path + "/method", "only for a derivative");
            else if (*method == "central_difference") d.method = Differentiator::central_difference;
            else if (*method == "savitzky_golay") d.method = Differentiator::savitzky_golay;
            else r.problem(path + "/method", "must be \"central_difference\" or \"savitzky_golay\", not '" + *method + "'");
        }
        if (o.contains("half_window")) {
            const json& h = o.at("half_window");
            if (d.method != Differentiator::savitzky_golay) r.problem(path + "/half_window", "only for savitzky_golay");
            else if (!h.is_number_unsigned() || h.get<int>() < 1 || h.get<int>() > kMaxSavitzkyGolayHalfWindow) {
                r.problem(path + "/half_window", "must be 1.." + std::to_string(kMaxSavitzkyGolayHalfWindow) + ", not " + h.dump());
            } else d.half_window = h.get<int>();
        }
        d.per_cycle = r.bool_at(o, path, "per_cycle").value_or(true);
        if (signal && r.check_name(*signal, path + "/signal")) {
            if (*signal == "time" || !names.insert(*signal).second) r.problem(path + "/signal", "'" + *signal + "' is named twice");
            d.signal = *signal;
        }
        m.derived.push_back(d);
    }
}

}  // namespace

ColumnMap parse_column_map(std::string_view json_text, const std::string& source) {
    std::string error;
    const auto parsed = io::parse_bounded_json(json_text, error);
    if (!parsed) throw MeasuredError("column map " + source + ": " + error);
    const json& root = *parsed;
    MapReader r(source);
    if (!root.is_object()) {
        r.problem("/", "must be a JSON object");
        r.throw_if_any();
    }
    ColumnMap m;
    m.path = source;
    m.sha256 = db::sha256_hex(json_text);
    r.only_keys(root, "", {"schema", "name", "description", "format", "columns", "unmapped_columns", "time", "cycles", "derived"});
    const auto schema = r.string_at(root, "", "schema", true);
    if (schema && *schema != kColumnMapSchema) r.problem("/schema", "'" + *schema + "' is not '" + std::string(kColumnMapSchema) + "'");
    m.name = r.string_at(root, "", "name", true).value_or("");
    (void)r.string_at(root, "", "description", false);
    const std::string unmapped = r.string_at(root, "", "unmapped_columns", false).value_or("error");
    if (unmapped != "error" && unmapped != "ignore") r.problem("/unmapped_columns", "must be \"error\" or \"ignore\", not '" + unmapped + "'");
    m.ignore_unmapped = unmapped == "ignore";
    read_format(r, root, m.format);
    std::set<std::string> names;
    read_columns(r, root, m, names);
    read_time(r, root, m.time);
    read_cycles(r, root, m.cycles);
    read_derived(r, root, m, names);
    if (m.time.source == TimeSource::column && m.time.restarts_per_cycle && m.cycles.source != CycleSource::column) {
        r.problem("/time/restarts_per_cycle", "a time that restarts per cycle needs the cycles from a column");
    }
    if (m.time.restarts_per_cycle && !m.time.rate_hz) {
        r.problem("/time/rate_hz", "missing: a time that restarts per cycle places each cycle one nominal period (1 / rate_hz) after the last");
    }
    if (m.cycles.source == CycleSource::motion) {
        // The cycles exist once their signal does: a per-cycle derivative must come after it.
        std::size_t defined_at = 0;
        for (std::size_t i = 0; i < m.derived.size(); ++i) {
            if (m.derived[i].signal == m.cycles.signal) defined_at = i + 1;
        }
        for (std::size_t i = 0; i < defined_at; ++i) {
            if (m.derived[i].op == DerivedOp::derivative && m.derived[i].per_cycle) {
                r.problem("/derived/" + std::to_string(i) + "/per_cycle", "the cycles come from the motion of '" + m.cycles.signal +
                                                                          "', derived later (/derived/" + std::to_string(defined_at - 1) +
                                                                          "): derive it first or set per_cycle false");
            }
        }
    }
    if (m.cycles.source == CycleSource::motion && !m.cycles.signal.empty() && !names.contains(m.cycles.signal)) {
        r.problem("/cycles/signal", "'" + m.cycles.signal + "' is not a signal of the map");
    }
    const bool by_index = !m.format.header;
    auto needs_index = [&](const ColumnRef& ref, const std::string& path) {
        if (by_index && ref.name) r.problem(path, "a file without a header names its columns by \"index\", not by name " + ref.describe());
    };
    for (std::size_t i = 0; i < m.signals.size(); ++i) needs_index(m.signals[i].column, "/columns (signal " + m.signals[i].signal + ")");
    for (const LabelColumnSpec& l : m.labels) needs_index(l.column, "/columns (label " + l.label + ")");
    if (m.time.source == TimeSource::column) needs_index(m.time.column, "/time");
    if (m.cycles.source == CycleSource::column) needs_index(m.cycles.column, "/cycles");
    r.throw_if_any();
    return m;
}

ColumnMap load_column_map(const std::string& path) {
    // Read the bytes once: the hash is of exactly the text parsed.
    std::string text, error;
    if (!io::read_bounded_text_file(path, text, error)) throw MeasuredError("column map " + path + ": " + error);
    return parse_column_map(text, path);
}

}  // namespace emadiag::measured
