#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <numeric>
#include <thread>

#include "dh/campaign/db.hpp"
#include "dh/campaign/plan.hpp"
#include "dh/campaign/progress.hpp"

using namespace dh;
using namespace dh::campaign;
namespace fs = std::filesystem;

namespace {
// A fresh folder per test under the system temp dir, removed afterwards.
struct TempDir : ::testing::Test {
  fs::path dir;
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir = fs::temp_directory_path() / ("dh_test_campaign_" + std::to_string(::getpid())) / info->name();
    fs::remove_all(dir);
  }
  void TearDown() override { fs::remove_all(dir.parent_path()); }
};

EpisodeRecord sample(const std::string& arm = "full", unsigned seed = 7) {
  EpisodeRecord r;
  r.arm = arm;
  r.cell = "goal-swap";
  r.task = 8;
  r.seed = seed;
  r.success = true;
  r.steps = 212;
  r.budget = 300;
  r.wall_s = 12.75;
  r.physics_s = 3.5;
  r.outcome = "success";
  r.reason = "On(bowl, plate) held";
  r.infrastructure = true;
  r.tick_limit = true;
  r.evidence_path = "runs/evidence/ep-1.jsonl";
  r.episode_id = "ep-1";
  r.worker = "sim_worker_0";
  r.channel = 3;
  r.finished_at = "2024-05-01T12:00:00Z";
  r.sim_success = false;
  r.sim_goal_step = -1;
  return r;
}

void expect_same(const EpisodeRecord& a, const EpisodeRecord& b) {
  EXPECT_EQ(a.arm, b.arm);
  EXPECT_EQ(a.cell, b.cell);
  EXPECT_EQ(a.task, b.task);
  EXPECT_EQ(a.seed, b.seed);
  EXPECT_EQ(a.success, b.success);
  EXPECT_EQ(a.steps, b.steps);
  EXPECT_EQ(a.budget, b.budget);
  EXPECT_DOUBLE_EQ(a.wall_s, b.wall_s);
  EXPECT_DOUBLE_EQ(a.physics_s, b.physics_s);
  EXPECT_EQ(a.outcome, b.outcome);
  EXPECT_EQ(a.reason, b.reason);
  EXPECT_EQ(a.infrastructure, b.infrastructure);
  EXPECT_EQ(a.tick_limit, b.tick_limit);
  EXPECT_EQ(a.evidence_path, b.evidence_path);
  EXPECT_EQ(a.episode_id, b.episode_id);
  EXPECT_EQ(a.worker, b.worker);
  EXPECT_EQ(a.channel, b.channel);
  EXPECT_EQ(a.finished_at, b.finished_at);
  EXPECT_EQ(a.sim_success, b.sim_success);
  EXPECT_EQ(a.sim_goal_step, b.sim_goal_step);
  EXPECT_EQ(a.sim_goal_at_end, b.sim_goal_at_end);
  EXPECT_EQ(a.capabilities_missing, b.capabilities_missing);
}

// The message of the exception `f` throws, or "" when it throws none of type E.
template <class E, class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  }
  return "";
}

// First column of the first row of `sql` on `path`, through SQLite directly.
std::string first_value(const fs::path& path, const char* sql) {
  sqlite3* db = nullptr;
  sqlite3_stmt* s = nullptr;
  std::string out;
  if (sqlite3_open(path.c_str(), &db) == SQLITE_OK &&
      sqlite3_prepare_v2(db, sql, -1, &s, nullptr) == SQLITE_OK && sqlite3_step(s) == SQLITE_ROW)
    out = reinterpret_cast<const char*>(sqlite3_column_text(s, 0));
  sqlite3_finalize(s);
  sqlite3_close(db);
  return out;
}

// A file as an older build wrote it: one sample() row, `version`, and `sql` run to take away what that
// version lacked. False if SQLite refused `sql`.
bool make_older(const fs::path& path, const std::string& version, const std::string& sql) {
  {
    auto db = CampaignDb::open(path);
    db.record(sample());
    db.set_meta("schema_version", version);
  }
  sqlite3* raw = nullptr;
  const bool ok = sqlite3_open(path.c_str(), &raw) == SQLITE_OK &&
                  sqlite3_exec(raw, sql.c_str(), nullptr, nullptr, nullptr) == SQLITE_OK;
  sqlite3_close(raw);
  return ok;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

const auto ten_tasks = [](const std::string&) { return std::vector<unsigned>{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}; };

using CampaignDbTest = TempDir;
}  // namespace

// --- database
// -----------------------------------------------------------------------------------------------

TEST_F(CampaignDbTest, EveryFieldRoundTripsAndFoldersAreCreated) {
  auto db = CampaignDb::open(dir / "a" / "b" / "campaign.db");
  EpisodeRecord r = sample();
  r.task = 4'000'000'000u;  // unsigned values above INT32_MAX survive
  r.reason = "quote ' and unicode ✓";
  EXPECT_TRUE(db.record(r));
  const auto rows = db.rows();
  ASSERT_EQ(rows.size(), 1u);
  expect_same(rows[0], r);
  EXPECT_TRUE(db.has("full", "goal-swap", 4'000'000'000u, 7));
  EXPECT_FALSE(db.has("static", "goal-swap", 4'000'000'000u, 7));
  EXPECT_EQ(db.meta("schema_version"), std::to_string(CampaignDb::kSchemaVersion));
  EXPECT_EQ(first_value(db.path(), "PRAGMA journal_mode"), "wal");
}

TEST_F(CampaignDbTest, ADuplicateKeyKeepsTheFirstRowAndReturnsFalse) {
  auto db = CampaignDb::open(dir / "c.db");
  ASSERT_TRUE(db.record(sample()));
  EpisodeRecord again = sample();
  again.success = false;
  again.outcome = "gave_up";
  EXPECT_FALSE(db.record(again));
  EXPECT_EQ(db.count(), 1u);
  EXPECT_EQ(db.rows()[0].outcome, "success");
}

TEST_F(CampaignDbTest, RowsComeOrderedByArmCellTaskSeed) {
  auto db = CampaignDb::open(dir / "c.db");
  for (unsigned seed : {3u, 1u, 2u}) db.record(sample("static", seed));
  db.record(sample("full", 9));
  std::vector<Key> keys;
  for (const auto& r : db.rows()) keys.push_back(key_of(r));
  const std::vector<Key> want = {{"full", "goal-swap", 8, 9},
                                 {"static", "goal-swap", 8, 1},
                                 {"static", "goal-swap", 8, 2},
                                 {"static", "goal-swap", 8, 3}};
  EXPECT_EQ(keys, want);
  EXPECT_EQ(db.finished(), std::set<Key>(want.begin(), want.end()));
}

TEST_F(CampaignDbTest, AReopenedFileKeepsItsRowsAndMeta) {
  const fs::path path = dir / "c.db";
  {
    auto db = CampaignDb::open(path);
    db.record(sample("full", 1));
    db.record(sample("full", 2));
    db.set_meta("salt", "17");
    db.set_meta("salt", "18");
  }
  auto db = CampaignDb::open(path);
  EXPECT_EQ(db.count(), 2u);
  EXPECT_TRUE(db.has("full", "goal-swap", 8, 2));
  EXPECT_FALSE(db.record(sample("full", 1)));
  EXPECT_EQ(db.meta("salt"), "18");
  EXPECT_EQ(db.meta("nothing"), std::nullopt);
  EXPECT_EQ(CampaignDb::read_rows(path).size(), 2u);
}

TEST_F(CampaignDbTest, ANonSqliteFileIsRefusedNamingIt) {
  fs::create_directories(dir);
  const fs::path path = dir / "notes.txt";
  std::ofstream(path) << "these are not the rows you are looking for, but long enough to have a header ......"
                         "..................................................................................";
  const auto msg = error_of<CampaignError>([&] { CampaignDb::open(path); });
  EXPECT_TRUE(contains(msg, path.string())) << msg;
  EXPECT_TRUE(contains(msg, "not a SQLite database")) << msg;
  EXPECT_TRUE(contains(msg, "--db")) << msg;
  EXPECT_TRUE(contains(error_of<CampaignError>([&] { CampaignDb::read_rows(path); }), path.string()));
}

TEST_F(CampaignDbTest, AnAlienSqliteFileIsRefusedAndLeftAsItWas) {
  fs::create_directories(dir);
  const fs::path path = dir / "other.db";
  sqlite3* raw = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &raw), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(raw, "CREATE TABLE things (x INTEGER)", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(raw);
  const auto msg = error_of<CampaignError>([&] { CampaignDb::open(path); });
  EXPECT_TRUE(contains(msg, path.string())) << msg;
  EXPECT_TRUE(contains(msg, "not a campaign database")) << msg;

  EXPECT_EQ(first_value(path, "SELECT count(*) FROM sqlite_master"), "1")
      << "the foreign file gained no tables";
  EXPECT_EQ(first_value(path, "PRAGMA journal_mode"), "delete") << "nor a journal mode";
}

TEST_F(CampaignDbTest, AnotherSchemaVersionIsRefused) {
  const fs::path path = dir / "c.db";
  CampaignDb::open(path).set_meta("schema_version", "99");
  const auto msg = error_of<CampaignError>([&] { CampaignDb::open(path); });
  EXPECT_TRUE(contains(msg, path.string())) << msg;
  EXPECT_TRUE(contains(msg, "version 99")) << msg;
}

TEST_F(CampaignDbTest, LostAttemptsAreKeptApartFromTheEpisodeRows) {
  auto db = CampaignDb::open(dir / "c.db");
  EpisodeRecord lost = sample();
  lost.episode_id = "attempt-1";
  lost.infrastructure = true;
  lost.outcome = "infrastructure";
  lost.reason = "worker sim2 lost";
  EXPECT_TRUE(db.record_loss(lost));
  EXPECT_FALSE(db.record_loss(lost)) << "one attempt is stored once";
  EXPECT_EQ(db.count(), 0u) << "a lost attempt is not the episode's row";
  EpisodeRecord rerun = sample();
  rerun.episode_id = "attempt-2";
  EXPECT_TRUE(db.record(rerun));
  const auto losses = CampaignDb::open(dir / "c.db").losses();
  ASSERT_EQ(losses.size(), 1u);
  expect_same(losses[0], lost);
  EXPECT_EQ(db.rows().size(), 1u);
}

TEST_F(CampaignDbTest, AVersionOneFileGainsTheLossesTableAndKeepsItsRows) {
  const fs::path path = dir / "v1.db";
  ASSERT_TRUE(make_older(path, "1", "DROP TABLE infrastructure_losses; DROP TABLE attribution"));
  EXPECT_TRUE(CampaignDb::read_rows(path).size() == 1u) << "read-only: readable as it is";
  auto db = CampaignDb::open(path);
  EXPECT_EQ(db.meta("schema_version"), std::to_string(CampaignDb::kSchemaVersion));
  EXPECT_EQ(db.count(), 1u);
  EpisodeRecord lost = sample();
  lost.episode_id = "attempt-1";
  EXPECT_TRUE(db.record_loss(lost));
  EXPECT_EQ(db.losses().size(), 1u);
}

TEST_F(CampaignDbTest, AVersionTwoFileGainsTheAttributionTableWhichKeepsOneLabelPerEpisodeAndFile) {
  const fs::path path = dir / "v2.db";
  ASSERT_TRUE(make_older(path, "2", "DROP TABLE attribution"));
  auto db = CampaignDb::open(path);
  EXPECT_EQ(db.meta("schema_version"), std::to_string(CampaignDb::kSchemaVersion));
  const EpisodeRecord r = sample();
  AttributionRow a{r.arm, r.cell, r.task, r.seed, "attr-1", 7, "capability_execution", true, "pick_place",
                   "grasp_missed", "lift", 40};
  AttributionRow other = a;
  other.seed = r.seed + 1;
  db.replace_attributions("attr-1", {a, other});
  a.layer = 8;
  a.name = "verification";
  db.replace_attributions("attr-1", {a});  // labelled again: the old labels go, the episode no longer labelled too
  AttributionRow coarse = a;
  coarse.config = "attr-2";
  coarse.layer = 3;
  coarse.name = "execution";
  db.replace_attributions("attr-2", {coarse});
  const auto rows = db.attributions("attr-1");
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].name, "verification");
  EXPECT_EQ(rows[0].layer, 8);
  EXPECT_TRUE(rows[0].harness);
  EXPECT_EQ(rows[0].failure, "grasp_missed");
  EXPECT_EQ(rows[0].step, 40u);
  EXPECT_EQ(db.attributions("attr-2").at(0).name, "execution");
  EXPECT_THROW(db.replace_attributions("attr-1", {coarse}), std::invalid_argument);
  EXPECT_EQ(db.attributions("attr-1").size(), 1u) << "a refused replacement changes nothing";
  EXPECT_EQ(CampaignDb::read_attributions(path, "attr-2").size(), 1u) << "read-only";
  EXPECT_TRUE(db.attributions("attr-3").empty());
}

TEST_F(CampaignDbTest, TheSimulatorsVerdictIsKeptAndADisagreementIsFlagged) {
  auto db = CampaignDb::open(dir / "v.db");
  EpisodeRecord agree = sample("full", 1), disagree = sample("full", 2), unknown = sample("full", 3);
  agree.sim_success = true;
  agree.sim_goal_step = 180;
  agree.sim_goal_at_end = true;
  disagree.sim_success = false;  // the governor says success (sample()), the simulator never saw the goal hold
  unknown.sim_success.reset();   // no report came
  for (const auto& r : {agree, disagree, unknown}) EXPECT_TRUE(db.record(r));
  const auto rows = db.rows();
  ASSERT_EQ(rows.size(), 3u);
  expect_same(rows[0], agree);
  expect_same(rows[1], disagree);
  expect_same(rows[2], unknown);
  EXPECT_FALSE(rows[0].verdict_disagrees());
  EXPECT_TRUE(rows[1].verdict_disagrees());
  EXPECT_FALSE(rows[2].verdict_disagrees());
  EXPECT_EQ(first_value(db.path(), "SELECT group_concat(seed) FROM episodes WHERE verdict_disagrees = 1"), "2");
}

TEST_F(CampaignDbTest, AVersionThreeFileReadsItsVerdictsAsUnknownAndGainsTheColumnsWhenWritten) {
  const fs::path path = dir / "v3.db";
  std::string drop;
  for (const char* table : {"episodes", "infrastructure_losses"})
    for (const char* column : {"sim_success", "sim_goal_step", "sim_goal_at_end", "verdict_disagrees"})
      drop += std::string("ALTER TABLE ") + table + " DROP COLUMN " + column + ";";
  ASSERT_TRUE(make_older(path, "3", drop));
  const auto old_rows = CampaignDb::read_rows(path);  // read-only: the file stays as it is
  ASSERT_EQ(old_rows.size(), 1u);
  EXPECT_FALSE(old_rows[0].sim_success.has_value());
  EXPECT_EQ(first_value(path, "SELECT value FROM meta WHERE key = 'schema_version'"), "3");
  auto db = CampaignDb::open(path);
  EXPECT_EQ(db.meta("schema_version"), std::to_string(CampaignDb::kSchemaVersion));
  EpisodeRecord next = sample("full", 8);
  next.sim_success = true;
  EXPECT_TRUE(db.record(next));
  const auto rows = db.rows();
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_FALSE(rows[0].sim_success.has_value()) << "an episode recorded before version 4 has no verdict";
  expect_same(rows[1], next);
}

TEST_F(CampaignDbTest, WhatAnEpisodeRanWithoutIsKeptNoneAndUnknownApart) {
  auto db = CampaignDb::open(dir / "m.db");
  EpisodeRecord without_two = sample("full", 1), with_all = sample("full", 2), unknown = sample("full", 3);
  without_two.capabilities_missing = std::vector<std::string>{"vla_act", "swing_door"};
  with_all.capabilities_missing = std::vector<std::string>{};
  for (const auto& r : {without_two, with_all, unknown}) EXPECT_TRUE(db.record(r));
  const auto rows = db.rows();
  ASSERT_EQ(rows.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) expect_same(rows[i], std::vector{without_two, with_all, unknown}[i]);
  EXPECT_EQ(first_value(db.path(), "SELECT capabilities_missing FROM episodes WHERE seed = 1"),
            "vla_act,swing_door");
  EXPECT_EQ(first_value(db.path(), "SELECT count(*) FROM episodes WHERE capabilities_missing IS NULL"), "1");
}

TEST_F(CampaignDbTest, AVersionFourFileReadsWhatItsEpisodesRanWithoutAsUnknown) {
  const fs::path path = dir / "v4.db";
  ASSERT_TRUE(make_older(path, "4",
                         "ALTER TABLE episodes DROP COLUMN capabilities_missing;"
                         "ALTER TABLE infrastructure_losses DROP COLUMN capabilities_missing;"));
  const auto old_rows = CampaignDb::read_rows(path);
  ASSERT_EQ(old_rows.size(), 1u);
  EXPECT_FALSE(old_rows[0].capabilities_missing.has_value());
  EXPECT_TRUE(old_rows[0].sim_success.has_value()) << "version 4's verdict columns are read";
  auto db = CampaignDb::open(path);
  EpisodeRecord next = sample("full", 8);
  next.capabilities_missing = std::vector<std::string>{"vla_act"};
  EXPECT_TRUE(db.record(next));
  const auto rows = db.rows();
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_FALSE(rows[0].capabilities_missing.has_value());
  expect_same(rows[1], next);
}

TEST_F(CampaignDbTest, ReadingAMissingFileNamesThePathAndCreatesNothing) {
  const fs::path path = dir / "missing.db";
  const auto msg = error_of<CampaignError>([&] { CampaignDb::read_rows(path); });
  EXPECT_TRUE(contains(msg, path.string())) << msg;
  EXPECT_FALSE(fs::exists(path));
}

TEST_F(CampaignDbTest, TheDeclaredPlanIsKeptAndAChangedPlanIsReported) {
  const fs::path path = dir / "c.db";
  const Plan plan{{"full", "static"}, {"goal"}, {}, {1, 2, 3}, "infrastructure once"};
  EXPECT_TRUE(CampaignDb::open(path).declare_plan(plan).empty());

  auto db = CampaignDb::open(path);
  EXPECT_EQ(db.plan(), plan);
  Plan reordered = plan;
  std::swap(reordered.arms[0], reordered.arms[1]);
  EXPECT_TRUE(db.declare_plan(reordered).empty()) << "order changes the schedule, not the campaign";

  Plan more = plan;
  more.seeds = {1, 2, 3, 4};
  const auto diff = db.declare_plan(more);
  ASSERT_EQ(diff.size(), 1u);
  EXPECT_EQ(diff[0], "seeds: stored 1-3, requested 1-4");
  EXPECT_EQ(db.plan(), plan) << "the stored plan is not overwritten";
}

TEST_F(CampaignDbTest, TwoHandlesOnOneFileBothWriteWithoutLockErrors) {
  const fs::path path = dir / "shared.db";
  auto a = CampaignDb::open(path);
  auto b = CampaignDb::open(path);
  constexpr unsigned n = 150;
  const auto write = [&](CampaignDb& db, const std::string& arm, std::string& error) {
    try {
      for (unsigned seed = 0; seed < n; ++seed) {
        db.record(sample(arm, seed));
        db.has(arm, "goal-swap", 8, seed);
      }
    } catch (const std::exception& e) {
      error = e.what();
    }
  };
  std::string error_a, error_b;
  std::thread ta(write, std::ref(a), "full", std::ref(error_a));
  std::thread tb(write, std::ref(b), "static", std::ref(error_b));
  ta.join();
  tb.join();
  EXPECT_EQ(error_a, "");
  EXPECT_EQ(error_b, "");
  EXPECT_EQ(a.count(), 2 * n);
  EXPECT_EQ(b.count(), 2 * n);
}

// --- plan
// ---------------------------------------------------------------------------------------------------

TEST(CampaignPlan, ParsesLists) {
  EXPECT_EQ(parse_list("full, static ,seq", "--arms"), (std::vector<std::string>{"full", "static", "seq"}));
  EXPECT_EQ(parse_list("goal", "--cells"), std::vector<std::string>{"goal"});
}

TEST(CampaignPlan, RejectsBadListsNamingOptionAndToken) {
  EXPECT_EQ(error_of<PlanError>([] { parse_list("", "--arms"); }),
            "--arms: nothing given (expected e.g. a,b)");
  EXPECT_EQ(error_of<PlanError>([] { parse_list("a,,b", "--arms"); }), "--arms: empty item in 'a,,b'");
  EXPECT_EQ(error_of<PlanError>([] { parse_list("a,b,a", "--cells"); }), "--cells: 'a' is given twice");
}

TEST(CampaignPlan, ParsesSeedsAndRanges) {
  std::vector<unsigned> want(20);
  std::iota(want.begin(), want.end(), 21u);
  EXPECT_EQ(parse_seeds("21-40"), want);
  EXPECT_EQ(parse_seeds("1,3,5-7"), (std::vector<unsigned>{1, 3, 5, 6, 7}));
  EXPECT_EQ(parse_seeds(" 9 , 4 - 5"), (std::vector<unsigned>{9, 4, 5})) << "order kept, blanks ignored";
  EXPECT_EQ(parse_seeds("4294967295"), std::vector<unsigned>{4294967295u});
  EXPECT_EQ(parse_numbers("0-2", "--tasks"), (std::vector<unsigned>{0, 1, 2}));
}

TEST(CampaignPlan, RejectsBadSeedsNamingOptionAndToken) {
  const auto err = [](const char* text) { return error_of<PlanError>([&] { parse_seeds(text); }); };
  EXPECT_EQ(err("5-3"), "--seeds: '5-3' is a descending range (write 3-5)");
  EXPECT_EQ(err(""), "--seeds: nothing given (expected e.g. 1-20 or 1,3,5-7)");
  EXPECT_EQ(err("x"), "--seeds: 'x' is not a non-negative integer or a range like 1-20");
  EXPECT_EQ(err("1,-3"), "--seeds: '-3' is not a non-negative integer or a range like 1-20");
  EXPECT_EQ(err("1-2-3"), "--seeds: '1-2-3' is not a non-negative integer or a range like 1-20");
  EXPECT_EQ(err("1,,2"), "--seeds: empty item in '1,,2'");
  EXPECT_EQ(err("4294967296"), "--seeds: '4294967296' is above 4294967295");
  EXPECT_EQ(err("1-99999999999999999999999"), "--seeds: '1-99999999999999999999999' is above 4294967295");
  EXPECT_EQ(err("1-5,3"), "--seeds: 3 is given twice ('1-5' and '3')");
  EXPECT_EQ(err("0-4294967295"), "--seeds: '0-4294967295' makes more than 1000000 numbers");
  EXPECT_TRUE(contains(error_of<PlanError>([] { parse_numbers("q", "--tasks"); }), "--tasks: 'q'"));
}

TEST(CampaignPlan, JsonRoundTrip) {
  const Plan p{{"full", "seq"}, {"goal", "long-swap"}, {8, 2}, {1000001, 5}, "none", "lib-0123", "vlm", "oracle", "ur7e"};
  EXPECT_EQ(plan_from_json(to_json(p)), p);
  Plan panda = p;
  panda.robot.clear();
  EXPECT_EQ(plan_differences(panda, p), (std::vector<std::string>{"robot: stored 'the scenes' own', requested 'ur7e'"}));
  EXPECT_EQ(plan_from_json(to_json(Plan{})), Plan{});
  EXPECT_TRUE(
      contains(error_of<PlanError>([] { plan_from_json("{\"arms\": 3}"); }), "stored plan is malformed"));
  EXPECT_TRUE(contains(error_of<PlanError>([] { plan_from_json("not json"); }), "stored plan is malformed"));
}

TEST(CampaignPlan, DifferencesNameEachChangedField) {
  const Plan a{{"full", "static"}, {"goal"}, {}, {1, 2, 3, 7}, "none"};
  EXPECT_TRUE(plan_differences(a, a).empty());
  Plan b = a;
  b.arms = {"full"};
  b.tasks = {8};
  b.rerun_rule = "infrastructure once";
  b.planner_errors = "vlm";
  const std::vector<std::string> want = {"arms: stored full,static, requested full",
                                         "tasks: stored every, requested 8",
                                         "rerun rule: stored 'none', requested 'infrastructure once'",
                                         "planner errors: stored '', requested 'vlm'"};
  EXPECT_EQ(plan_differences(a, b), want);
}

TEST(CampaignPlan, ExpandIsSeedMajorWithArmsAdjacent) {
  const Plan p{{"full", "static"}, {"goal", "long"}, {}, {5, 6}, ""};
  const auto tasks_of = [](const std::string& cell) {
    return cell == "goal" ? std::vector<unsigned>{0, 1, 2} : std::vector<unsigned>{4};
  };
  const auto keys = expand(p, tasks_of);
  ASSERT_EQ(keys.size(), 2u * (3 + 1) * 2);
  const std::vector<Key> head = {{"full", "goal", 0, 5},   {"static", "goal", 0, 5}, {"full", "goal", 1, 5},
                                 {"static", "goal", 1, 5}, {"full", "goal", 2, 5},   {"static", "goal", 2, 5},
                                 {"full", "long", 4, 5},   {"static", "long", 4, 5}, {"full", "goal", 0, 6}};
  EXPECT_EQ(std::vector<Key>(keys.begin(), keys.begin() + head.size()), head);
  EXPECT_EQ(std::set<Key>(keys.begin(), keys.end()).size(), keys.size()) << "no episode twice";
}

TEST(CampaignPlan, ExpandSizeIsArmsCellsTasksSeeds) {
  const Plan p{{"a", "b", "c"}, {"goal", "goal-swap"}, {1, 8}, {1, 2, 3, 4, 5}, ""};
  EXPECT_EQ(expand(p, ten_tasks).size(), 3u * 2 * 2 * 5);
  EXPECT_EQ(expand(Plan{{"a"}, {"goal"}, {}, {1, 2}, ""}, ten_tasks).size(), 1u * 1 * 10 * 2);
}

TEST(CampaignPlan, ExpandRejectsATaskTheCellLacks) {
  const Plan p{{"a"}, {"goal"}, {12}, {1}, ""};
  EXPECT_EQ(error_of<PlanError>([&] { expand(p, ten_tasks); }),
            "--tasks: task 12 is not in cell 'goal' (its tasks: 0-9)");
}

TEST(CampaignPlan, RemainingKeepsOrderAndDropsFinished) {
  const auto all = expand(Plan{{"full", "static"}, {"goal"}, {1, 2}, {1, 2}, ""}, ten_tasks);
  const std::set<Key> done = {all[0], all[1], all[5]};
  const auto left = remaining(all, done);
  const std::vector<Key> want = {all[2], all[3], all[4], all[6], all[7]};
  EXPECT_EQ(left, want);
  EXPECT_EQ(remaining(all, {}), all);
  EXPECT_TRUE(remaining(all, std::set<Key>(all.begin(), all.end())).empty());
}

TEST(CampaignPlan, FreshSeedBlocksAreDeterministicDistinctAndAboveDevelopmentSeeds) {
  const auto a = fresh_seed_block(500, 17);
  EXPECT_EQ(a, fresh_seed_block(500, 17));
  EXPECT_EQ(a.size(), 500u);
  EXPECT_EQ(std::set<unsigned>(a.begin(), a.end()).size(), a.size());
  for (unsigned s : a) EXPECT_GE(s, 1'000'000u);
  EXPECT_NE(a, fresh_seed_block(500, 18));
  const auto longer = fresh_seed_block(600, 17);
  EXPECT_EQ(std::vector<unsigned>(longer.begin(), longer.begin() + 500), a)
      << "a block extends, never reshuffles";
  EXPECT_TRUE(fresh_seed_block(0, 17).empty());
  EXPECT_TRUE(contains(error_of<PlanError>([] { fresh_seed_block(2'000'000, 1); }), "--fresh-seeds"));
}

// --- progress
// -----------------------------------------------------------------------------------------------

TEST(CampaignProgress, BeforeTheFirstEpisodeTheRateIsUnknown) {
  const auto t0 = Progress::Clock::time_point{} + std::chrono::hours(1);
  const Progress p(800, 0, 0, 0, t0);
  EXPECT_EQ(p.line(t0 + std::chrono::seconds(5)),
            "[................]    0/800  success --  infra 0  -- ep/s  ETA --");
}

TEST(CampaignProgress, LineShowsBarCountsRateAndEta) {
  const auto t0 = Progress::Clock::time_point{} + std::chrono::hours(1);
  Progress p(800, 100, 60, 1, t0);  // resumed: 100 done before this run
  for (int i = 0; i < 23; ++i) p.finished(i % 2 == 0, i == 0);
  // 123/800 done, 72 successes, 2 infra; 23 episodes in 10 s → 2.3 ep/s, 677 left → 294 s.
  EXPECT_EQ(p.line(t0 + std::chrono::seconds(10)),
            "[##..............]  123/800  success 58.5%  infra 2  2.3 ep/s  ETA 4m54s");
  EXPECT_EQ(p.line(t0 + std::chrono::seconds(10), 4),
            "[....]  123/800  success 58.5%  infra 2  2.3 ep/s  ETA 4m54s");
  EXPECT_EQ(p.line(t0), "[##..............]  123/800  success 58.5%  infra 2  -- ep/s  ETA --")
      << "no time yet";
  EXPECT_EQ(p.done(), 123u);
  EXPECT_EQ(p.successes(), 72u);
}

TEST(CampaignProgress, SlowAndFinishedCampaigns) {
  const auto t0 = Progress::Clock::time_point{};
  Progress p(4, 0, 0, 0, t0);
  p.finished(true, false);
  EXPECT_EQ(p.line(t0 + std::chrono::seconds(50), 8),
            "[##......]  1/4  success 100.0%  infra 0  0.02 ep/s  ETA 2m30s");
  for (int i = 0; i < 3; ++i) p.finished(false, false);
  EXPECT_EQ(p.line(t0 + std::chrono::seconds(100), 8),
            "[########]  4/4  success 25.0%  infra 0  0.04 ep/s  ETA 0s");
  EXPECT_EQ(p.render(t0 + std::chrono::seconds(100), true, 8),
            "\r[########]  4/4  success 25.0%  infra 0  0.04 ep/s  ETA 0s\x1b[K");
  EXPECT_EQ(p.render(t0 + std::chrono::seconds(100), false, 8).back(), '\n');
}

TEST(CampaignProgress, DurationFormat) {
  EXPECT_EQ(format_duration(0), "0s");
  EXPECT_EQ(format_duration(59.4), "59s");
  EXPECT_EQ(format_duration(293.6), "4m54s");
  EXPECT_EQ(format_duration(3600 + 5 * 60 + 40), "1h05m");
}
