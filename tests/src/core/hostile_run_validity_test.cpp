// Issue 21 items 2 and 3: only a complete, valid run may give a verdict (core/run_validity.hpp), and
// the run CSV reader refuses nonsense metadata and physically impossible samples with file:line.
#include "core/emadiag_error.hpp"
#include "core/run_csv.hpp"
#include "core/run_validity.hpp"
#include "core/sim_run.hpp"
#include "emadiag/sim/simulator.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sstream>

using namespace emadiag;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

namespace {

/// A complete DYN run of the simulator, noiseless, case B.
const Run& complete_run() {
    static const Run run = [] {
        sim::SimConfig c;
        c.load_case = sim::LoadCase::B;
        c.sequence = sim::Sequence::Dyn;
        return make_run(c, sim::simulate(c));
    }();
    return run;
}

std::string csv_of(const Run& run) {
    std::ostringstream os;
    write_run_csv(os, run);
    return os.str();
}

Run read(const std::string& text) {
    std::istringstream in(text);
    return read_run_csv(in, "run.csv");
}

/// The run CSV text with `line` (1-based) replaced.
std::string with_line(const std::string& text, std::size_t line, const std::string& replacement) {
    std::istringstream in(text);
    std::string out, l;
    for (std::size_t n = 1; std::getline(in, l); ++n) out += (n == line ? replacement : l) + "\n";
    return out;
}

std::size_t line_of(const std::string& text, const std::string& prefix) {
    std::istringstream in(text);
    std::string l;
    for (std::size_t n = 1; std::getline(in, l); ++n)
        if (l.rfind(prefix, 0) == 0) return n;
    return 0;
}

}  // namespace

TEST(HostileRunValidity, ACompleteSimulatedRunIsValid) {
    const RunValidity v = run_validity(complete_run());
    EXPECT_TRUE(v.valid) << v.reason;
    EXPECT_EQ(complete_run().samples.size(), 1000u);
    const RunValidity again = run_validity(read(csv_of(complete_run())));
    EXPECT_TRUE(again.valid) << again.reason;
}

TEST(HostileRunValidity, ATruncatedRunIsNotValidAndSaysHowManySamples) {
    emadiag::Run run = complete_run();
    run.samples.resize(462);
    const RunValidity v = run_validity(run);
    EXPECT_FALSE(v.valid);
    EXPECT_THAT(v.reason, AllOf(HasSubstr("truncated"), HasSubstr("462 of 1000 samples"), HasSubstr("0.5 s")));
    // One sample lost at the end is within the tolerance (a candump log may lose 0.1 % anywhere).
    run = complete_run();
    run.samples.pop_back();
    EXPECT_TRUE(run_validity(run).valid) << run_validity(run).reason;
}

TEST(HostileRunValidity, MetadataValidFalseOrAnIncompleteStatusIsNotValid) {
    emadiag::Run run = complete_run();
    run.set_meta("valid", "false");
    run.set_meta("invalid_reason", "sequence incomplete");
    EXPECT_THAT(run_validity(run).reason, HasSubstr("valid=false (sequence incomplete)"));
    for (const char* status : {"incomplete", "aborted"}) {
        run = complete_run();
        run.set_meta("status", status);
        const RunValidity v = run_validity(run);
        EXPECT_FALSE(v.valid) << status;
        EXPECT_THAT(v.reason, HasSubstr(std::string("status=") + status));
    }
    run = complete_run();
    run.set_meta("status", "complete");
    run.set_meta("valid", "true");
    EXPECT_TRUE(run_validity(run).valid);
    // A reason without valid=false contradicts itself: not judged (the probe's csv-invalid-reason).
    run = complete_run();
    run.set_meta("invalid_reason", "telemetry loss");
    const RunValidity v = run_validity(run);
    EXPECT_FALSE(v.valid);
    EXPECT_THAT(v.reason, HasSubstr("invalid_reason=telemetry loss"));
}

TEST(HostileRunValidity, AnImpossibleSampleMakesARunInvalid) {
    emadiag::Run run = complete_run();
    run.samples[17].current_a = 1e308;
    const RunValidity v = run_validity(run);
    EXPECT_FALSE(v.valid);
    EXPECT_THAT(v.reason, AllOf(HasSubstr("sample 18"), HasSubstr("current_A = 1e+308"), HasSubstr("I_max = 20 A")));
    EXPECT_DOUBLE_EQ(*sample_magnitude_limit("current_A"), kImpossibleMargin * 20.0);
    EXPECT_FALSE(sample_magnitude_limit("t_s"));
}

TEST(HostileRunValidity, TheCsvReaderRefusesAnUnknownCaseSequenceStatusOrValidWithTheLine) {
    const std::string text = csv_of(complete_run());
    const struct { const char* key; const char* bad; const char* allowed; } cases[] = {
        {"case", "Z", "A, A-ext, B"},
        {"sequence", "zz", "dyn, brk, sweep"},
    };
    for (const auto& c : cases) {
        const std::size_t line = line_of(text, std::string("# ") + c.key + "=");
        ASSERT_GT(line, 0u) << c.key;
        const std::string bad = with_line(text, line, std::string("# ") + c.key + "=" + c.bad);
        EXPECT_THAT([&] { (void)read(bad); },
                    ThrowsMessage<EmadiagError>(AllOf(HasSubstr("run.csv:" + std::to_string(line) + ":"),
                                                      HasSubstr(std::string(c.key) + "=" + c.bad + " is not one of " + c.allowed))));
    }
    // status and valid are added as new lines right after the first metadata line.
    const std::string status = with_line(text, 1, "# status=maybe\n" + text.substr(0, text.find('\n')));
    EXPECT_THAT([&] { (void)read(status); },
                ThrowsMessage<EmadiagError>(AllOf(HasSubstr("run.csv:1:"), HasSubstr("status=maybe is not one of complete, aborted, incomplete"))));
    const std::string valid = with_line(text, 1, "# valid=yes\n" + text.substr(0, text.find('\n')));
    EXPECT_THAT([&] { (void)read(valid); }, ThrowsMessage<EmadiagError>(HasSubstr("valid=yes is not one of true, false")));
}

TEST(HostileRunValidity, TheCsvReaderRefusesAPhysicallyImpossibleSampleWithLineColumnAndValue) {
    const std::string text = csv_of(complete_run());
    const std::size_t header = line_of(text, "t_s,");
    ASSERT_GT(header, 0u);
    const std::size_t line = header + 18;
    const RunSample& s = complete_run().samples[17];
    const std::string row = format_exact(s.t_s) + ",1e308," + format_exact(s.speed_rad_s) + "," + format_exact(s.theta_m_rad) + "," +
                            format_exact(s.hinge_moment_nm) + "," + format_exact(s.command_deg);
    EXPECT_THAT([&] { (void)read(with_line(text, line, row)); },
                ThrowsMessage<EmadiagError>(AllOf(HasSubstr("run.csv:" + std::to_string(line) + ": column 'current_A'"),
                                                  HasSubstr("1e+308 is physically impossible"), HasSubstr("+/-100"))));
    // A value just inside the margin is a measurement: read.
    const std::string fast = format_exact(s.t_s) + "," + format_exact(s.current_a) + ",4000," + format_exact(s.theta_m_rad) + "," +
                             format_exact(s.hinge_moment_nm) + "," + format_exact(s.command_deg);
    EXPECT_NO_THROW((void)read(with_line(text, line, fast)));
}
