// The CAN corpus is a test (issue 25 part 5): 190 public DBC files parse as the corpus manifest
// expects (cantools' lenient verdict, malformed files refused with file:line:col), every reference
// decode of golden.jsonl (cantools 36.2.0) is matched, and every candump log gives what its manifest
// says. The corpus is in shared/corpus beside the checkout (tests/support/corpus.hpp).
#include "emadiag/can/can_error.hpp"
#include "emadiag/can/candump_log.hpp"
#include "emadiag/can/dbc.hpp"
#include "support/corpus.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>

using namespace emadiag::can;

namespace {

std::vector<std::vector<std::string>> read_tsv(const std::string& path) {
    std::ifstream in(path);
    std::vector<std::vector<std::string>> rows;
    std::string line;
    bool header = true;
    while (std::getline(in, line)) {
        if (header) {
            header = false;
            continue;
        }
        std::vector<std::string> cols;
        std::stringstream ss(line);
        std::string c;
        while (std::getline(ss, c, '\t')) cols.push_back(c);
        rows.push_back(cols);
    }
    return rows;
}

std::string source_of(const std::string& path) { return path.substr(0, path.find('/')); }

/// Parses `path` (relative to corpus/dbc); the error text when refused.
std::optional<std::string> refusal(const std::string& path, DbcMode mode, Database* out = nullptr) {
    try {
        Database db = parse_dbc_file(emadiag::test::corpus_dir() + "/dbc/" + path, mode);
        if (out) *out = std::move(db);
        return std::nullopt;
    } catch (const CanError& e) {
        return std::string(e.what());
    }
}

}  // namespace

TEST(CanCorpus, EveryDbcParsesAsTheManifestExpects) {
    EMADIAG_REQUIRE_CORPUS();
    const auto rows = read_tsv(emadiag::test::corpus_dir() + "/dbc/MANIFEST.tsv");
    ASSERT_EQ(rows.size(), 190U) << "dbc/MANIFEST.tsv rows";
    struct Tally {
        int accepted = 0, refused = 0, expect_accept = 0, expect_reject = 0, either = 0, strict_agree = 0, files = 0;
    };
    std::map<std::string, Tally> by_source;
    std::vector<std::string> wrong;
    const std::regex located(R"(:[0-9]+:[0-9]+: )");
    for (const auto& r : rows) {
        ASSERT_GE(r.size(), 5U);
        const std::string& path = r[0];
        const std::string& strict_ref = r[1];
        const std::string& expect = r[4];
        Tally& t = by_source[source_of(path)];
        ++t.files;
        const auto lenient = refusal(path, DbcMode::Lenient);
        (lenient ? t.refused : t.accepted) += 1;
        if (expect == "accept") {
            ++t.expect_accept;
            if (lenient) wrong.push_back(path + ": expected accept, refused:\n" + lenient->substr(0, 4000));
        } else if (expect == "reject") {
            ++t.expect_reject;
            if (!lenient) wrong.push_back(path + ": expected reject (" + r[5].substr(0, 120) + "), accepted");
            else if (!std::regex_search(*lenient, located)) wrong.push_back(path + ": refused without file:line:col: " + lenient->substr(0, 300));
        } else {
            ++t.either;
        }
        // Strict mode against cantools strict=True (reported, not scored: cantools' strict checks
        // are not all the same as ours).
        const bool strict_ok = !refusal(path, DbcMode::Strict);
        if (strict_ok == (strict_ref == "OK")) ++t.strict_agree;
    }
    std::string table = "source                 files accepted refused expect-accept expect-reject either strict-agrees-with-cantools\n";
    for (const auto& [src, t] : by_source) {
        char line[200];
        std::snprintf(line, sizeof line, "%-22s %5d %8d %7d %13d %13d %6d %d\n", src.c_str(), t.files, t.accepted, t.refused, t.expect_accept,
                      t.expect_reject, t.either, t.strict_agree);
        table += line;
    }
    std::printf("%s", table.c_str());
    EXPECT_TRUE(wrong.empty()) << wrong.size() << " files not as the manifest expects:\n" << ::testing::PrintToString(wrong);
}

TEST(CanCorpus, EveryReferenceDecodeMatchesCantools) {
    EMADIAG_REQUIRE_CORPUS();
    std::ifstream in(emadiag::test::corpus_dir() + "/dbc/golden.jsonl");
    ASSERT_TRUE(in) << "no dbc/golden.jsonl";
    std::map<std::string, std::optional<Database>> dbs;
    std::size_t frames = 0, matched = 0, values = 0;
    std::vector<std::string> wrong;
    auto report = [&](const std::string& what) {
        if (wrong.size() < 40) wrong.push_back(what);
    };
    std::string line;
    std::vector<DecodedSignal> decoded;
    while (std::getline(in, line)) {
        if (line.empty()) continue;
        ++frames;
        const auto j = nlohmann::json::parse(line);
        const std::string dbc = j.at("dbc").get<std::string>();
        auto it = dbs.find(dbc);
        if (it == dbs.end()) {
            Database db;
            const auto refused = refusal(dbc, DbcMode::Lenient, &db);
            it = dbs.emplace(dbc, refused ? std::nullopt : std::optional<Database>(std::move(db))).first;
        }
        const std::string where = dbc + " frame " + std::to_string(j.at("frame_id").get<std::uint64_t>()) + " " + j.at("data").get<std::string>();
        if (!it->second) {
            report(where + ": the DBC was refused");
            continue;
        }
        const Message* m = it->second->find_message(j.at("frame_id").get<std::uint32_t>(), j.at("is_extended").get<bool>());
        if (m == nullptr) {
            report(where + ": no such message");
            continue;
        }
        const std::string hex = j.at("data").get<std::string>();
        std::vector<std::uint8_t> data(hex.size() / 2);
        for (std::size_t i = 0; i < data.size(); ++i) data[i] = static_cast<std::uint8_t>(std::stoul(hex.substr(2 * i, 2), nullptr, 16));
        std::string err;
        if (!m->decode(data.data(), data.size(), decoded, &err)) {
            report(where + ": " + err);
            continue;
        }
        const auto& expected = j.at("signals");
        std::set<std::string> ours, theirs;
        for (const auto& d : decoded) ours.insert(d.signal->name);
        for (const auto& [k, v] : expected.items()) theirs.insert(k);
        bool ok = ours == theirs;
        if (!ok) report(where + ": signals " + ::testing::PrintToString(ours) + ", cantools " + ::testing::PrintToString(theirs));
        for (const auto& d : decoded) {
            if (!expected.contains(d.signal->name)) continue;
            ++values;
            const auto& v = expected.at(d.signal->name);
            const Signal& s = *d.signal;
            const bool exact_int = v.is_number_integer() && s.value_type == ValueType::Integer && s.factor == 1.0 && s.offset == 0.0;
            if (exact_int) {
                // 64-bit values: compared as integers, not through a double.
                std::uint64_t raw = d.raw;
                if (s.is_signed && s.length < 64 && ((raw >> (s.length - 1)) & 1U)) raw |= ~s.layout.mask;
                const bool same = s.is_signed ? static_cast<std::int64_t>(raw) == v.get<std::int64_t>()
                                              : (v.is_number_unsigned() ? raw == v.get<std::uint64_t>() : false);
                if (!same) {
                    ok = false;
                    report(where + ": " + s.name + " raw " + std::to_string(raw) + ", cantools " + v.dump());
                }
                continue;
            }
            const double want = v.get<double>();
            if (!(std::fabs(d.value - want) <= 1e-9 * std::max(1.0, std::fabs(want)))) {
                ok = false;
                char buf[160];
                std::snprintf(buf, sizeof buf, "%.17g", d.value);
                report(where + ": " + s.name + " = " + buf + ", cantools " + v.dump());
            }
        }
        if (ok) ++matched;
    }
    std::printf("golden.jsonl: %zu frames, %zu matched, %zu signal values compared, %zu DBC files\n", frames, matched, values, dbs.size());
    EXPECT_EQ(frames, 11624U);
    EXPECT_EQ(matched, frames) << ::testing::PrintToString(wrong);
}

TEST(CanCorpus, EveryCandumpLogGivesWhatItsManifestSays) {
    EMADIAG_REQUIRE_CORPUS();
    const auto rows = read_tsv(emadiag::test::corpus_dir() + "/candump/MANIFEST.tsv");
    ASSERT_EQ(rows.size(), 14U) << "candump/MANIFEST.tsv rows";
    const std::regex skip_line(R"(^skip line ([0-9]+) with a warning)");
    const std::regex data_and_errors(R"(^([0-9]+) data \+ ([0-9]+) error frames)");
    for (const auto& r : rows) {
        ASSERT_GE(r.size(), 5U);
        const std::string path = emadiag::test::corpus_dir() + "/candump/" + r[0];
        const std::string& expected = r[3];
        const std::string& robust = r[4];
        SCOPED_TRACE(r[0] + ": " + robust);
        CandumpReport rep;
        if (robust.rfind("refuse with a hint", 0) == 0) {
            EXPECT_THAT([&] { (void)read_candump_file(path, CandumpMode::Lenient, &rep); },
                        ::testing::ThrowsMessage<CanError>(::testing::AllOf(::testing::HasSubstr(path + ":1:"), ::testing::HasSubstr("candump -l"))));
            continue;
        }
        std::vector<CandumpRecord> recs;
        ASSERT_NO_THROW(recs = read_candump_file(path, CandumpMode::Lenient, &rep));
        std::smatch m;
        if (std::regex_search(expected, m, data_and_errors)) {
            EXPECT_EQ(rep.frames, std::stoul(m[1]));
            EXPECT_EQ(rep.error_frames, std::stoul(m[2]));
        } else {
            EXPECT_EQ(rep.frames, std::stoul(expected));
            EXPECT_EQ(rep.error_frames, 0U);
        }
        EXPECT_EQ(recs.size(), rep.frames + rep.error_frames);
        if (std::regex_search(robust, m, skip_line)) {
            EXPECT_EQ(rep.skipped_lines + rep.can_xl_lines + rep.dropcount_lines, 1U);
            const std::string at = path + ":" + m[1].str() + ":";
            bool named = false;
            for (const auto& msg : rep.messages) named = named || msg.rfind(at, 0) == 0;
            EXPECT_TRUE(named) << "no message names line " << m[1] << ": " << ::testing::PrintToString(rep.messages);
        } else {
            EXPECT_EQ(robust, "read all");
            EXPECT_EQ(rep.skipped_lines + rep.can_xl_lines + rep.dropcount_lines, 0U) << ::testing::PrintToString(rep.messages);
        }
    }
}
