// `emadiag trend --format html --out FILE` end to end (docs/report-html.md): a simulated history, the
// HTML file written whole with its plots, and the errors of a bad output path. The browser check is
// scripts/report/browser_check.sh (ctest label browser).
#include "support/cli_runner.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

using Result = emadiag::test::CliResult;
Result run(const std::string& args, bool merge_stderr = true) { return emadiag::test::run_cli(args, merge_stderr); }

std::size_t count(const std::string& text, const std::string& what) {
    std::size_t n = 0;
    for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
    return n;
}

class TrendHtmlCli : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = std::filesystem::temp_directory_path() / ("emadiag_trend_html_cli_" + std::to_string(getpid()));
        std::filesystem::create_directories(dir_);
        history_ = run("history-sim --db " + db() + " --tail N123EM --sessions 6 --days-between 30 --fdj-start 0.08 --fdj-rate-per-100d 0.004 --seed 2");
    }
    static void TearDownTestSuite() { std::filesystem::remove_all(dir_); }
    static std::string db() { return (dir_ / "history.db").string(); }
    static inline std::filesystem::path dir_;
    static inline Result history_;
};

TEST_F(TrendHtmlCli, WritesOneSelfContainedFileWithThePlots) {
    ASSERT_EQ(history_.exit_code, 0) << history_.output;
    const std::string out = (dir_ / "report.html").string();
    const Result r = run("trend --db " + db() + " --tail N123EM --format html --out " + out);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("wrote the html report of N123EM to " + out));
    std::ifstream f(out);
    std::stringstream ss;
    ss << f.rdbuf();
    const std::string html = ss.str();
    EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
    EXPECT_EQ(count(html, "<svg"), 4u);
    EXPECT_EQ(count(html, "class=\"errorbar\""), 12u);  // FDJ and FSJ, 6 sessions each
    EXPECT_THAT(html, AllOf(HasSubstr("Position (none)"), Not(HasSubstr("Position ALL")), HasSubstr("Session history (6)"), HasSubstr(">crossing "), Not(HasSubstr("<script"))));
    EXPECT_FALSE(std::filesystem::exists(out + ".tmp"));
}

TEST_F(TrendHtmlCli, HtmlToStandardOutputAndJsonThroughFormat) {
    ASSERT_EQ(history_.exit_code, 0) << history_.output;
    const Result html = run("trend --db " + db() + " --tail N123EM --format html", false);
    ASSERT_EQ(html.exit_code, 0);
    EXPECT_EQ(html.output.rfind("<!DOCTYPE html>", 0), 0u);
    const Result json = run("trend --db " + db() + " --tail N123EM --format json", false);
    const Result flag = run("trend --db " + db() + " --tail N123EM --json", false);
    EXPECT_EQ(json.output, flag.output);
    EXPECT_THAT(run("trend --db " + db() + " --tail N123EM --format pdf").output, HasSubstr("--format"));
}

TEST_F(TrendHtmlCli, AnUnwritableOutputIsAClearErrorAndLeavesNothing) {
    ASSERT_EQ(history_.exit_code, 0) << history_.output;
    const std::string out = (dir_ / "no-such-dir" / "report.html").string();
    const Result r = run("trend --db " + db() + " --tail N123EM --format html --out " + out);
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.output, HasSubstr(out + ": cannot create a temporary file in " + (dir_ / "no-such-dir").string() +
                                    ": No such file or directory; nothing was written"));
    EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace
