// The maintenance database against :memory: and temporary files: round trips, one-transaction
// stores, migrations, and misuse.
#include "emadiag/db/db_error.hpp"
#include "emadiag/db/run_store.hpp"
#include "support/lone_run.hpp"
#include "support/stored_run_example.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

namespace emadiag::db {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

StoredRun example_run(const std::string& tail = "F-WEMA") { return test::example_stored_run("dyn", tail); }

TEST(RunStore, StoreThenLoadGivesBackEverything) {
    Database db(":memory:");
    EXPECT_EQ(db.schema_version(), 7);
    const StoredRun in = example_run();
    const auto id = test::store_lone_run(db, in);
    const StoredRun out = load_run(db, id);
    EXPECT_EQ(out.tail_number, in.tail_number);
    EXPECT_EQ(out.actuator_serial, in.actuator_serial);
    ASSERT_EQ(out.samples.size(), in.samples.size());
    EXPECT_EQ(out.samples[7].speed_rad_s, in.samples[7].speed_rad_s);
    EXPECT_EQ(out.raw_log, in.raw_log) << "raw logs are kept byte for byte";
    ASSERT_EQ(out.estimates.size(), 2U);
    EXPECT_EQ(out.estimates[0].parameter, "FDJ_Nm");
    EXPECT_DOUBLE_EQ(*out.estimates[0].value, 0.081);
    EXPECT_FALSE(out.estimates[1].value.has_value());
    EXPECT_FALSE(out.estimates[1].identifiable);
}

TEST(RunStore, ListsRunsPerTailNumber) {
    Database db(":memory:");
    (void)test::store_lone_run(db, example_run("F-WEMA"));
    (void)test::store_lone_run(db, example_run("F-WEMB"));
    (void)test::store_lone_run(db, example_run("F-WEMA"));
    EXPECT_EQ(list_runs(db, "F-WEMA").size(), 2U);
    EXPECT_EQ(list_runs(db, "F-WEMB").size(), 1U);
    EXPECT_TRUE(list_runs(db, "F-NONE").empty());
}

TEST(RunStore, InvalidRunWritesNothing) {
    Database db(":memory:");
    StoredRun bad = example_run();
    bad.samples[3].current_a = std::nan("");
    EXPECT_THAT([&] { (void)test::store_lone_run(db, bad); }, ThrowsMessage<DbError>(HasSubstr("current_a of sample 3 is not a finite number")));
    bad = example_run();
    bad.estimates.push_back({"physics", "FDJ_Nm", 0.08, 0.001, true, "dup", ""});  // violates the primary key mid-transaction
    EXPECT_THAT([&] { (void)test::store_lone_run(db, bad); }, ThrowsMessage<DbError>(HasSubstr("failed")));
    EXPECT_TRUE(list_runs(db, "F-WEMA").empty()) << "the failed store was rolled back whole";
}

TEST(RunStore, MisuseIsAClearError) {
    Database db(":memory:");
    EXPECT_THAT([&] { (void)test::store_lone_run(db, example_run("f wema")); },
                ThrowsMessage<DbError>(HasSubstr("tail number 'f wema' is not valid")));
    StoredRun no_log = example_run();
    no_log.raw_log.clear();
    EXPECT_THAT([&] { (void)test::store_lone_run(db, no_log); }, ThrowsMessage<DbError>(HasSubstr("has no raw log")));
    EXPECT_THAT([&] { (void)load_run(db, 99); }, ThrowsMessage<DbError>(HasSubstr("no run with id 99")));
    EXPECT_THAT([&] { Statement st(db, "SELEC nonsense"); }, ThrowsMessage<DbError>(HasSubstr("cannot prepare 'SELEC nonsense'")));
    Transaction tx(db);
    tx.commit();
    EXPECT_THAT([&] { tx.commit(); }, ThrowsMessage<DbError>(HasSubstr("already committed")));
}

TEST(Database, ReopensAFileWithoutMigratingTwiceAndRefusesNewerSchemas) {
    // One file per process: another build directory may run this test at the same time.
    const auto path =
        (std::filesystem::temp_directory_path() / ("emadiag_db_test_" + std::to_string(::getpid()) + ".sqlite")).string();
    std::filesystem::remove(path);
    {
        Database db(path);
        (void)test::store_lone_run(db, example_run());
    }
    {
        Database db(path);
        EXPECT_EQ(db.schema_version(), 7);
        EXPECT_EQ(list_runs(db, "F-WEMA").size(), 1U);
        db.exec("PRAGMA user_version = 99");
    }
    EXPECT_THAT([&] { Database db(path); }, ThrowsMessage<DbError>(HasSubstr("schema version 99, newer than")));
    std::filesystem::remove(path);
    EXPECT_THAT([] { Database db("/nonexistent/dir/x.sqlite"); }, ThrowsMessage<DbError>(HasSubstr("cannot open database")));
}

}  // namespace
}  // namespace emadiag::db
