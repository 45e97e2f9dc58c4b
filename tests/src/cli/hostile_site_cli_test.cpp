// `emadiag site` against hostile output folders (issue 26 part 5): a folder holding anything the tool
// did not write, a symbolic link or a file is refused and left as it was; an earlier site is replaced
// whole. Hostile tail names: hostile_site_file_name_test.cpp (the database refuses them before). The browser check is scripts/report/site_browser_check.sh.
#include "support/cli_runner.hpp"
#include "support/db_test_files.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

namespace fs = std::filesystem;
using emadiag::test::run_cli;

std::string read(const fs::path& p) { return emadiag::test::read_text_file(p.string()); }

class HostileSiteCli : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = fs::temp_directory_path() / ("emadiag_hostile_site_cli_" + std::to_string(getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
        for (const char* tail : {"N1EM", "N2-EM", "N3EM"})
            ASSERT_EQ(run_cli("history-sim --db " + db() + " --tail " + tail + " --sessions 3 --days-between 30 --seed 1").exit_code, 0);
    }
    static void TearDownTestSuite() { fs::remove_all(dir_); }
    static std::string db() { return (dir_ / "fleet.db").string(); }
    static inline fs::path dir_;
};

TEST_F(HostileSiteCli, EveryTailHasItsPageLinkedBothWays) {
    const fs::path site = dir_ / "site";
    const auto r = run_cli("site --db " + db() + " --out " + site.string() + " --threads 2");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("index.html and 3 tail pages"));
    const std::string index = read(site / "index.html");
    for (const char* f : {"tail-N1EM.html", "tail-N2-EM.html", "tail-N3EM.html"}) {
        ASSERT_TRUE(fs::exists(site / "tails" / f)) << f;
        EXPECT_THAT(index, HasSubstr("href=\"tails/" + std::string(f) + "\"")) << f;
        EXPECT_THAT(read(site / "tails" / f), HasSubstr("<a href=\"../index.html\">")) << f;
    }
    EXPECT_THAT(index, AllOf(HasSubstr("default-src 'none'"), Not(HasSubstr("<script")), Not(HasSubstr("http://")), Not(HasSubstr("https://"))));
    EXPECT_TRUE(fs::exists(site / ".emadiag-site"));
    // Readable like any new folder (mkdtemp's 0700 is not kept).
    EXPECT_NE(fs::status(site).permissions() & fs::perms::others_read, fs::perms::none);
}

TEST_F(HostileSiteCli, AFolderWithForeignFilesIsRefusedAndLeftAlone) {
    const fs::path out = dir_ / "notes";
    fs::create_directories(out / "tails");
    std::ofstream(out / "tails" / "mine.txt") << "keep";
    const auto r = run_cli("site --db " + db() + " --out " + out.string());
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, AllOf(HasSubstr("mine.txt"), HasSubstr("which this command did not write")));
    EXPECT_EQ(read(out / "tails" / "mine.txt"), "keep");
    EXPECT_FALSE(fs::exists(out / "index.html"));
    // An index.html alone, without the marker, is not a site of ours either.
    const fs::path other = dir_ / "other";
    fs::create_directories(other);
    std::ofstream(other / "index.html") << "someone's page";
    const auto r2 = run_cli("site --db " + db() + " --out " + other.string());
    EXPECT_NE(r2.exit_code, 0);
    EXPECT_THAT(r2.output, HasSubstr("has no .emadiag-site"));
    EXPECT_EQ(read(other / "index.html"), "someone's page");
    // No staging folder is left beside them.
    for (const auto& e : fs::directory_iterator(dir_)) EXPECT_THAT(e.path().filename().string(), Not(HasSubstr(".new-")));
}

TEST_F(HostileSiteCli, ASymlinkOrAFileIsRefused) {
    const fs::path target = dir_ / "elsewhere";
    fs::create_directories(target);
    const fs::path link = dir_ / "link";
    fs::create_directory_symlink(target, link);
    const auto r = run_cli("site --db " + db() + " --out " + link.string());
    EXPECT_NE(r.exit_code, 0);
    EXPECT_THAT(r.output, HasSubstr("is a symbolic link"));
    EXPECT_TRUE(fs::is_empty(target));
    std::ofstream(dir_ / "plain") << "x";
    const auto f = run_cli("site --db " + db() + " --out " + (dir_ / "plain").string());
    EXPECT_NE(f.exit_code, 0);
    EXPECT_THAT(f.output, HasSubstr("exists and is not a folder"));
}

TEST_F(HostileSiteCli, AnEarlierSiteIsReplacedWhole) {
    const fs::path site = dir_ / "again";
    ASSERT_EQ(run_cli("site --db " + db() + " --out " + site.string()).exit_code, 0);
    std::ofstream(site / "tails" / "tail-GONE.html") << "a tail page of an earlier fleet";
    const auto r = run_cli("site --db " + db() + " --out " + site.string());
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_FALSE(fs::exists(site / "tails" / "tail-GONE.html"));
    EXPECT_TRUE(fs::exists(site / "index.html"));
}

}  // namespace

TEST_F(HostileSiteCli, LongHistoriesAreSummarisedAndEverySessionIsInTheLinkedList) {
    const fs::path site = dir_ / "summarised";
    // Three sessions a tail: above --full-history-max 2 each position (and its serial) is summarised.
    const auto r = run_cli("site --db " + db() + " --out " + site.string() + " --full-history-max 2 --recent-sessions 1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("index.html and 3 tail pages, 3 session lists"));
    for (const char* tail : {"N1EM", "N2-EM", "N3EM"}) {
        const std::string list = "tail-" + std::string(tail) + ".position-1.csv";
        const std::string page = read(site / "tails" / ("tail-" + std::string(tail) + ".html"));
        EXPECT_THAT(page, HasSubstr("Long history: 3 sessions.")) << tail;
        EXPECT_THAT(page, HasSubstr("Session history (3, 1 listed)")) << tail;
        // The serial holds the position's sessions: both sections link the one list.
        EXPECT_EQ(page.find("href=\"" + list + "\"") != std::string::npos, true) << tail;
        EXPECT_NE(page.find("href=\"" + list + "\"", page.find("id=\"serial-1\"")), std::string::npos) << tail;
        EXPECT_FALSE(fs::exists(site / "tails" / ("tail-" + std::string(tail) + ".serial-1.csv"))) << tail;
        const std::string csv = read(site / "tails" / list);
        EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 4) << csv;
    }
    // An earlier site with its lists is replaced whole; without the option nothing is summarised.
    const auto again = run_cli("site --db " + db() + " --out " + site.string());
    ASSERT_EQ(again.exit_code, 0) << again.output;
    EXPECT_FALSE(fs::exists(site / "tails" / "tail-N1EM.position-1.csv"));
    EXPECT_THAT(read(site / "tails" / "tail-N1EM.html"), Not(HasSubstr("Long history")));
    // A list the tool did not write (no tail- prefix) makes the folder foreign.
    std::ofstream(site / "tails" / "notes.csv") << "mine";
    const auto foreign = run_cli("site --db " + db() + " --out " + site.string());
    EXPECT_NE(foreign.exit_code, 0);
    EXPECT_THAT(foreign.output, HasSubstr("notes.csv, which this command did not write"));
    EXPECT_TRUE(fs::exists(site / "tails" / "notes.csv"));
}
