// Text that tries to get in (issue 12 part 4): SQL metacharacters, markup and script, NUL bytes,
// Unicode and very long strings in every text field of a stored test session, its runs, estimates
// and findings. Every field is bound as a parameter, never spliced into SQL: each comes back byte
// for byte and the schema is untouched. Tail numbers are validated: hostile ones are refused with
// a short message naming the rule.
#include "emadiag/db/database.hpp"
#include "emadiag/db/db_error.hpp"
#include "emadiag/db/run_store.hpp"
#include "emadiag/db/session_store.hpp"

#include "support/stored_run_example.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

using namespace emadiag;
using ::testing::HasSubstr;

namespace {

const std::vector<std::string>& hostile_texts() {
    static const std::vector<std::string> t = {
        "'; DROP TABLE test_sessions; --",
        "\" OR \"1\"=\"1",
        "x'); DELETE FROM runs WHERE ('1'='1",
        "%_\\' ESCAPE '\\",
        "<script>alert('x')</script>",
        "<img src=x onerror=alert(1)>&amp;&lt;",
        std::string("nul\0byte", 8),
        "Ünïcödé ✈ 飞机 \xF0\x9F\x9B\xA9",
        "\xFF\xFE not UTF-8",
        std::string(100000, 'A'),
        "line1\nline2\r\n\ttab",
    };
    return t;
}

TEST(HostileText, EveryTextFieldRoundTripsByteForByteAndTheSchemaStays) {
    db::Database d(":memory:");
    for (const std::string& text : hostile_texts()) {
        db::StoredTestSession s;
        s.tail_number = "F-WEMA";
        s.actuator_serial = text;
        s.phase = "pre-flight";
        s.started_utc = "2026-11-22T20:00:00Z" + text;  // the ISO prefix is checked; the rest is kept
        s.tool_version = text;
        s.verdict = "INCONCLUSIVE";
        s.verdict_note = text;
        s.limits_json = text;
        db::StoredRun r = test::example_stored_run("dyn", "F-WEMA");
        r.actuator_serial = text;
        r.source = text;
        r.load_case = text;
        r.sequence = text;
        r.status_note = text;
        r.meta_json = text;
        r.raw_log_format = text;
        r.raw_log = text;
        r.estimates[0].method = text;
        r.estimates[0].note = text;
        s.runs.push_back(r);
        db::StoredFinding f;
        f.parameter = text;
        f.estimator = text;
        f.status = text;
        f.note = text;
        s.findings.push_back(f);
        const std::int64_t id = db::store_test_session(d, s);
        const db::StoredTestSession back = db::load_test_session(d, id);
        EXPECT_EQ(back.actuator_serial, text);
        EXPECT_EQ(back.started_utc, s.started_utc);
        EXPECT_EQ(back.tool_version, text);
        EXPECT_EQ(back.verdict_note, text);
        EXPECT_EQ(back.limits_json, text);
        ASSERT_EQ(back.runs.size(), 1u);
        const db::StoredRun& br = back.runs[0];
        EXPECT_EQ(br.actuator_serial, text);
        EXPECT_EQ(br.source, text);
        EXPECT_EQ(br.load_case, text);
        EXPECT_EQ(br.sequence, text);
        EXPECT_EQ(br.status_note, text);
        EXPECT_EQ(br.meta_json, text);
        EXPECT_EQ(br.raw_log_format, text);
        EXPECT_EQ(br.raw_log, text);
        ASSERT_FALSE(br.estimates.empty());
        bool found = false;
        for (const auto& e : br.estimates) found = found || (e.method == text && e.note == text);
        EXPECT_TRUE(found);
        ASSERT_EQ(back.findings.size(), 1u);
        EXPECT_EQ(back.findings[0].parameter, text);
        EXPECT_EQ(back.findings[0].estimator, text);
        EXPECT_EQ(back.findings[0].status, text);
        EXPECT_EQ(back.findings[0].note, text);
    }
    // Nothing was dropped or deleted: every session is there, and the schema is whole.
    EXPECT_EQ(db::list_test_sessions(d, "F-WEMA").size(), hostile_texts().size());
    db::Statement st(d, "SELECT COUNT(*) FROM sqlite_master WHERE type = 'table' AND name IN ('test_sessions', 'runs', 'findings')");
    ASSERT_TRUE(st.step());
    EXPECT_EQ(st.column_int(0), 3);
}

TEST(HostileText, HostileTailNumbersAreRefusedWithAShortMessage) {
    db::Database d(":memory:");
    std::vector<std::string> tails = hostile_texts();
    tails.push_back("");
    tails.push_back("n123em");              // lower case
    tails.push_back("N123\xC3\x89M");       // N123ÉM: Unicode
    tails.push_back("../../etc/passwd");   // a path, should a tail ever name a file
    tails.push_back(std::string(17, 'N'));  // one too long
    tails.push_back(std::string(1 << 20, 'N'));
    for (const std::string& tail : tails) {
        SCOPED_TRACE(tail.substr(0, 40));
        db::StoredTestSession s;
        s.tail_number = tail;
        s.phase = "pre-flight";
        s.started_utc = "2026-11-22T20:00:00Z";
        s.verdict = "NO_TEST";
        try {
            (void)db::store_test_session(d, s);
            ADD_FAILURE() << "stored a session under a hostile tail number";
        } catch (const db::DbError& e) {
            EXPECT_THAT(e.what(), HasSubstr("is not valid: use 1 to 16 characters of A-Z, 0-9 and '-'"));
            EXPECT_LT(std::string(e.what()).size(), 300u) << "the message echoes the whole input";
        }
        EXPECT_THROW((void)db::list_test_sessions(d, tail), db::DbError);
        EXPECT_THROW((void)db::list_runs(d, tail), db::DbError);
    }
    EXPECT_EQ(db::list_test_sessions(d, "F-WEMA").size(), 0u);
}

}  // namespace
