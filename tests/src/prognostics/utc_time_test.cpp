// UTC times of test sessions on a day axis: the accepted form, every rejected one with its reason,
// and the way back to calendar dates.
#include "core/emadiag_error.hpp"
#include "prognostics/utc_time.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace emadiag::prognostics {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

constexpr double kDayTolerance = 1e-9;  // days: well below a millisecond
constexpr double kHalfSecondDays = 0.5 / kSecondsPerDay;

double parse(const std::string& s) {
    std::string problem;
    const auto d = parse_utc_days(s, problem);
    EXPECT_TRUE(d.has_value()) << s << ": " << problem;
    return d.value_or(-1);
}

std::string problem_of(const std::string& s) {
    std::string problem;
    EXPECT_FALSE(parse_utc_days(s, problem).has_value()) << s << " was accepted";
    return problem;
}

TEST(UtcTime, CountsDaysFromTheEpochAcrossLeapYears) {
    EXPECT_NEAR(parse("1970-01-01T00:00:00"), 0.0, kDayTolerance);
    // 30 years of 365 days and the leap days of 1972 ... 1996 (7), then January and a leap February.
    EXPECT_NEAR(parse("2000-03-01T00:00:00Z"), 30 * 365 + 7 + 31 + 29, kDayTolerance);
    EXPECT_NEAR(parse("2026-01-06T08:00:00Z") - parse("2026-01-05T08:00:00Z"), 1.0, kDayTolerance);
    EXPECT_NEAR(parse("2026-01-05T20:00:00") - parse("2026-01-05T08:00:00Z"), 0.5, kDayTolerance);
}

TEST(UtcTime, AcceptsAFractionOfASecondWithOrWithoutZ) {
    EXPECT_NEAR(parse("2026-01-05T08:00:00.5Z") - parse("2026-01-05T08:00:00Z"), kHalfSecondDays, kDayTolerance);
    EXPECT_NEAR(parse("2026-01-05T08:00:00.500000") - parse("2026-01-05T08:00:00"), kHalfSecondDays, kDayTolerance);
}

TEST(UtcTime, RejectsEverythingElseAndSaysWhy) {
    EXPECT_THAT(problem_of("2026-01-05"), HasSubstr("expected YYYY-MM-DDThh:mm:ss"));
    EXPECT_THAT(problem_of("2026-01-05 08:00:00"), HasSubstr("character 11"));
    EXPECT_THAT(problem_of("2026-01-05T08:00:00+02:00"), HasSubstr("time zone offsets are not accepted"));
    EXPECT_THAT(problem_of("2026-01-05T08:00:00."), HasSubstr("without fraction digits"));
    EXPECT_THAT(problem_of("2026-01-05T08:00:00ZZ"), HasSubstr("unexpected \"Z\""));
    EXPECT_THAT(problem_of("2026-13-01T00:00:00Z"), HasSubstr("month 13"));
    EXPECT_THAT(problem_of("2026-02-29T00:00:00Z"), HasSubstr("day 29 is not in 2026-02"));
    EXPECT_THAT(problem_of("2026-01-05T24:00:00Z"), HasSubstr("not within 00:00:00 to 23:59:59"));
    EXPECT_THAT(problem_of(""), HasSubstr("expected YYYY-MM-DDThh:mm:ss"));
}

TEST(UtcTime, TheThrowingFormNamesWhatAndTheValue) {
    EXPECT_THAT([] { (void)parse_utc_days_or_throw("yesterday", "--start-utc"); },
                ThrowsMessage<EmadiagError>(AllOf(HasSubstr("--start-utc"), HasSubstr("\"yesterday\""), HasSubstr("YYYY-MM-DD"))));
}

TEST(UtcTime, FormatsBackToTheSameTimeAndDate) {
    for (const std::string s : {"1970-01-01T00:00:00Z", "2000-02-29T23:59:59Z", "2026-01-05T08:00:00Z", "2100-12-31T12:34:56Z"}) {
        EXPECT_EQ(format_utc_time(parse(s)), s);
        EXPECT_EQ(format_utc_date(parse(s)), s.substr(0, 10));
    }
    EXPECT_EQ(format_utc_time(parse("2026-01-05T08:00:00Z") + 210.0), "2026-08-03T08:00:00Z");
}

}  // namespace
}  // namespace emadiag::prognostics
