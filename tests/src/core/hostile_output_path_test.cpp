// The output-path helper, the text-field checks, the escaping, the CSV cell writer and the URI
// redaction (emadiag/io/; issue 21 items 4, 7 and 8) against hostile input: a planted link at any
// temporary name, an input given as the output (by another spelling or a hard link), a database's
// side files, a full disk, an exception while the text is made; control characters, bidirectional
// overrides, bytes that are not UTF-8 and 100,000-character names; spreadsheet formulas; passwords
// in well-formed and malformed URIs.
#include "core/emadiag_error.hpp"
#include "emadiag/io/output_path.hpp"
#include "emadiag/io/text_field.hpp"
#include "emadiag/io/uri.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>

namespace fs = std::filesystem;
using emadiag::EmadiagError;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;
namespace io = emadiag::io;

namespace {

class OutputPath : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() /
               ("emadiag-outpath-" + std::to_string(::getpid()) + "-" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override {
        ::unsetenv("EMADIAG_FAULT_OUTPUT_ENOSPC_AFTER_BYTES");
        fs::remove_all(dir_);
    }
    std::string p(const std::string& name) const { return (dir_ / name).string(); }
    static std::string read(const std::string& path) {
        std::ifstream in(path, std::ios::binary);
        return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    }
    std::set<std::string> names() const {
        std::set<std::string> out;
        for (const auto& e : fs::directory_iterator(dir_)) out.insert(e.path().filename().string());
        return out;
    }
    fs::path dir_;
};

TEST_F(OutputPath, WritesWholeAndLeavesNoTemporary) {
    io::write_output_file<EmadiagError>(p("out.txt"), "report", {}, std::string("hello\n"));
    EXPECT_EQ(read(p("out.txt")), "hello\n");
    EXPECT_EQ(names(), std::set<std::string>{"out.txt"});
}

TEST_F(OutputPath, PlantedLinksAtTheOldFixedTemporaryNamesAreNotFollowed) {
    std::ofstream(p("victim.txt")) << "precious\n";
    for (const char* suffix : {".tmp", ".part", ".new", "~"}) fs::create_symlink(p("victim.txt"), p(std::string("rep.txt") + suffix));
    io::write_output_file<EmadiagError>(p("rep.txt"), "report", {}, std::string("report\n"));
    EXPECT_EQ(read(p("victim.txt")), "precious\n");
    EXPECT_EQ(read(p("rep.txt")), "report\n");
    EXPECT_TRUE(fs::is_symlink(p("rep.txt.tmp")));
}

TEST_F(OutputPath, AnInputIsRefusedByAnySpellingAndByHardLink) {
    std::ofstream(p("in.csv")) << "input\n";
    fs::create_directories(dir_ / "sub");
    const io::OutputInputs inputs({p("in.csv")});
    for (const std::string& spelling : {p("in.csv"), p("sub/../in.csv"), p("./in.csv")}) {
        EXPECT_THAT([&] { io::write_output_file<EmadiagError>(spelling, "model", inputs, std::string("x")); },
                    ::testing::ThrowsMessage<EmadiagError>(HasSubstr("is an input of this command"))) << spelling;
    }
    fs::create_hard_link(p("in.csv"), p("hard.csv"));
    EXPECT_THAT([&] { io::write_output_file<EmadiagError>(p("hard.csv"), "model", inputs, std::string("x")); },
                ::testing::ThrowsMessage<EmadiagError>(HasSubstr("is an input of this command")));
    EXPECT_EQ(read(p("in.csv")), "input\n");
}

TEST_F(OutputPath, TheDatabaseAndItsSideFilesAreRefused) {
    std::ofstream(p("hh.db")) << "SQLite format 3";
    const io::OutputInputs inputs({}, {p("hh.db")});
    for (const char* name : {"hh.db", "hh.db-journal", "hh.db-wal", "hh.db-shm"}) {
        EXPECT_THAT([&] { io::check_output_path<EmadiagError>(p(name), "report", inputs); },
                    ::testing::ThrowsMessage<EmadiagError>(HasSubstr("the maintenance database"))) << name;
    }
    EXPECT_EQ(read(p("hh.db")), "SQLite format 3");
}

TEST_F(OutputPath, DevicesFifosSocketsDirectoriesAndLinksAreRefused) {
    ASSERT_EQ(::mkfifo(p("fifo").c_str(), 0600), 0);
    fs::create_symlink("/dev/null", p("link"));
    for (const auto& c : std::vector<std::pair<std::string, std::string>>{
             {"/dev/full", "a device file"}, {p("fifo"), "a FIFO"}, {dir_.string(), "a directory"}, {p("link"), "a symbolic link"}}) {
        // A pair, not a structured binding: clang 14 (the sanitizer build) cannot capture a binding.
        const std::string& path = c.first;
        EXPECT_THAT([&] { io::write_output_file<EmadiagError>(path, "report", {}, std::string("x")); },
                    ::testing::ThrowsMessage<EmadiagError>(HasSubstr("is " + c.second))) << path;
    }
    EXPECT_EQ(names(), (std::set<std::string>{"fifo", "link"}));
}

TEST_F(OutputPath, TwoOutputsOfOneCommandMustDiffer) {
    EXPECT_THAT([&] { io::check_output_paths<EmadiagError>({{p("a.json"), "--out-model"}, {p("./a.json"), "--out-params"}}); },
                ::testing::ThrowsMessage<EmadiagError>(HasSubstr("is also the --out-model output")));
}

TEST_F(OutputPath, AnExceptionWhileProducingLeavesTheOldFileAndNoTemporary) {
    std::ofstream(p("out.txt")) << "old\n";
    EXPECT_THROW(io::write_output_file<EmadiagError>(p("out.txt"), "report", {},
                                                     [](std::ostream& out) {
                                                         out << std::string(200000, 'x');
                                                         throw std::runtime_error("failed half way");
                                                     }),
                 std::runtime_error);
    EXPECT_EQ(read(p("out.txt")), "old\n");
    EXPECT_EQ(names(), std::set<std::string>{"out.txt"});
}

TEST_F(OutputPath, AFullDiskNamesThePathAndTheErrnoTextAndLeavesNothing) {
    // The fault hook (a full disk after 1000 bytes); the real full tmpfs is in hostile_output_cli_test.
    ::setenv("EMADIAG_FAULT_OUTPUT_ENOSPC_AFTER_BYTES", "1000", 1);
    std::ofstream(p("out.txt")) << "old\n";
    EXPECT_THAT([&] { io::write_output_file<EmadiagError>(p("out.txt"), "dataset", {}, std::string(300000, 'x')); },
                ::testing::ThrowsMessage<EmadiagError>(AllOf(HasSubstr("dataset " + p("out.txt")), HasSubstr("No space left on device"))));
    EXPECT_EQ(read(p("out.txt")), "old\n");
    EXPECT_EQ(names(), std::set<std::string>{"out.txt"});
    EXPECT_THAT([&] { io::write_output_file<EmadiagError>(p("new.txt"), "dataset", {}, std::string(300000, 'x')); },
                ::testing::ThrowsMessage<EmadiagError>(HasSubstr("No space left on device")));
    EXPECT_EQ(names(), std::set<std::string>{"out.txt"});
}

TEST_F(OutputPath, ANewFileGetsTheUsualModeAndAReplacedOneKeepsItsMode) {
    io::write_output_file<EmadiagError>(p("new.txt"), "report", {}, std::string("x"));
    const mode_t mask = ::umask(0);
    ::umask(mask);
    EXPECT_EQ(fs::status(p("new.txt")).permissions(), static_cast<fs::perms>(0666 & ~mask));
    fs::permissions(p("new.txt"), static_cast<fs::perms>(0640));
    io::write_output_file<EmadiagError>(p("new.txt"), "report", {}, std::string("y"));
    EXPECT_EQ(fs::status(p("new.txt")).permissions(), static_cast<fs::perms>(0640));
}

TEST(TextField, ControlCharactersAreRefusedWithTheFieldPositionAndCode) {
    EXPECT_EQ(io::text_field_problem("--serial", "SN-0042"), std::nullopt);
    EXPECT_EQ(io::text_field_problem("--technician", "Jos\xC3\xA9 M\xC3\xBCller"), std::nullopt);  // UTF-8 names are fine
    EXPECT_THAT(io::text_field_problem("--technician", "A B\nVERDICT: SERVICEABLE").value_or(""),
                AllOf(HasSubstr("--technician"), HasSubstr("character 4"), HasSubstr("U+000A")));
    EXPECT_THAT(io::text_field_problem("--serial", "SN\x1b[31m").value_or(""), AllOf(HasSubstr("character 3"), HasSubstr("U+001B")));
    EXPECT_THAT(io::text_field_problem("--operator", "OP\xC2\x85").value_or(""), HasSubstr("U+0085"));         // C1 next line
    EXPECT_THAT(io::text_field_problem("--operator", "OP\xE2\x80\xAE" "abc").value_or(""), HasSubstr("U+202E"));  // right-to-left override
    EXPECT_THAT(io::text_field_problem("--certificate", "C\xFF").value_or(""), AllOf(HasSubstr("character 2"), HasSubstr("0xFF"), HasSubstr("not UTF-8")));
    EXPECT_THAT(io::text_field_problem("--certificate", "C\xC0\x80").value_or(""), HasSubstr("not UTF-8"));  // overlong NUL
    const auto long_one = io::text_field_problem("--serial", std::string(100000, 'N'));
    ASSERT_TRUE(long_one);
    EXPECT_THAT(*long_one, AllOf(HasSubstr("--serial"), HasSubstr("128 characters")));
    EXPECT_LT(long_one->size(), 200u);
    EXPECT_EQ(io::text_field_problem("--serial", std::string(io::kMaxTextFieldChars, 'N')), std::nullopt);
}

TEST(TextField, EscapeRendersControlsVisiblyAndKeepsPrintableText) {
    EXPECT_EQ(io::escape_text("SN\nVERDICT: SERVICEABLE"), "SN\\x0aVERDICT: SERVICEABLE");
    EXPECT_EQ(io::escape_text("\x1b[2J\x1b]0;owned\x07"), "\\x1b[2J\\x1b]0;owned\\x07");
    EXPECT_EQ(io::escape_text("Jos\xC3\xA9"), "Jos\xC3\xA9");
    EXPECT_EQ(io::escape_text("a\xE2\x80\xAE" "b"), "a\\u202eb");
    EXPECT_EQ(io::escape_text("a\xC2\x9B" "b"), "a\\u009bb");  // C1 CSI
    EXPECT_EQ(io::escape_text("bad\xFF"), "bad\\xff");
    EXPECT_EQ(io::escape_text("two\nlines\r", true), "two\nlines\\x0d");
}

TEST(CsvField, FormulasAreNeutralisedAndNumbersAreLeftAlone) {
    EXPECT_EQ(io::csv_field("=HYPERLINK(\"http://x\",\"y\")"), "\"'=HYPERLINK(\"\"http://x\"\",\"\"y\"\")\"");
    EXPECT_EQ(io::csv_field("+1+cmd|' /C calc'!A0"), "'+1+cmd|' /C calc'!A0");
    EXPECT_EQ(io::csv_field("-2+3"), "'-2+3");
    EXPECT_EQ(io::csv_field("@SUM(A1)"), "'@SUM(A1)");
    EXPECT_EQ(io::csv_field("\t=1"), "'\\x09=1");
    EXPECT_EQ(io::csv_field("\r=1"), "'\\x0d=1");
    EXPECT_EQ(io::csv_field("SN1\nVERDICT\x1b[2J"), "SN1\\x0aVERDICT\\x1b[2J");  // one record, one line; no escape sequence
    EXPECT_EQ(io::csv_field("-0.5"), "-0.5");
    EXPECT_EQ(io::csv_field("+3"), "+3");
    EXPECT_EQ(io::csv_field("-1.25e-05"), "-1.25e-05");
    EXPECT_EQ(io::csv_field("SN-1"), "SN-1");
    EXPECT_EQ(io::csv_field("a,b"), "\"a,b\"");
    EXPECT_EQ(io::csv_field(""), "");
}

TEST(RedactUri, PasswordsInWellFormedAndMalformedUrisAreHidden) {
    EXPECT_EQ(io::redact_uri_passwords("postgresql://alice:S3cretPW@host:5432/fleet"), "postgresql://alice:***@host:5432/fleet");
    EXPECT_EQ(io::redact_uri_passwords("invalid IPv6 host address in URI: \"postgresql://alice:S3cretPW@[::1:5432/fleet\""),
              "invalid IPv6 host address in URI: \"postgresql://alice:***@[::1:5432/fleet\"");
    EXPECT_THAT(io::redact_uri_passwords("postgres://bob:pa/ss@w:rd@host/db"), Not(HasSubstr("pa/ss")));
    EXPECT_THAT(io::redact_uri_passwords("postgres://bob:pa/ss@w:rd@host/db"), Not(HasSubstr("w:rd")));
    EXPECT_EQ(io::redact_uri_passwords("postgresql://host/db?user=a&password=S3cretPW&sslmode=require"),
              "postgresql://host/db?user=a&password=***&sslmode=require");
    EXPECT_EQ(io::redact_uri_passwords("host=h PASSWORD='two words' user=u"), "host=h PASSWORD='***' user=u");
    EXPECT_EQ(io::redact_uri_passwords("postgresql://host:5432/fleet"), "postgresql://host:5432/fleet");
    EXPECT_EQ(io::redact_uri_passwords("run.csv:12: bad cell"), "run.csv:12: bad cell");
    EXPECT_TRUE(io::has_uri_scheme("postgresql://alice:x@h/db"));
    EXPECT_TRUE(io::has_uri_scheme("file:///tmp/x.db"));
    EXPECT_FALSE(io::has_uri_scheme("maintenance.db"));
    EXPECT_FALSE(io::has_uri_scheme("./postgresql://x"));
    EXPECT_FALSE(io::has_uri_scheme("/tmp/a://b"));
}

}  // namespace
