#include "dh/campaign/db.hpp"

#include <sqlite3.h>

#include "comma_list.hpp"

namespace dh::campaign {

namespace {
constexpr const char* kSchema = R"sql(
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT);
CREATE TABLE episodes (
  arm TEXT NOT NULL, cell TEXT NOT NULL, task INTEGER NOT NULL, seed INTEGER NOT NULL,
  success INTEGER NOT NULL, steps INTEGER NOT NULL, budget INTEGER NOT NULL,
  wall_s REAL NOT NULL, physics_s REAL NOT NULL, outcome TEXT NOT NULL, reason TEXT NOT NULL,
  infrastructure INTEGER NOT NULL, tick_limit INTEGER NOT NULL, evidence_path TEXT NOT NULL,
  episode_id TEXT NOT NULL, worker TEXT NOT NULL, channel INTEGER NOT NULL, finished_at TEXT NOT NULL,
  PRIMARY KEY (arm, cell, task, seed));
)sql";

// Version 2: attempts lost to infrastructure and run again under the plan's rerun rule (same columns).
constexpr const char* kLossesTable = R"sql(
CREATE TABLE IF NOT EXISTS infrastructure_losses (
  arm TEXT NOT NULL, cell TEXT NOT NULL, task INTEGER NOT NULL, seed INTEGER NOT NULL,
  success INTEGER NOT NULL, steps INTEGER NOT NULL, budget INTEGER NOT NULL,
  wall_s REAL NOT NULL, physics_s REAL NOT NULL, outcome TEXT NOT NULL, reason TEXT NOT NULL,
  infrastructure INTEGER NOT NULL, tick_limit INTEGER NOT NULL, evidence_path TEXT NOT NULL,
  episode_id TEXT NOT NULL PRIMARY KEY, worker TEXT NOT NULL, channel INTEGER NOT NULL, finished_at TEXT NOT NULL);
)sql";

// Version 3: each failed episode's attribution (issue 16) under one attribution file (its content hash).
constexpr const char* kAttributionTable = R"sql(
CREATE TABLE IF NOT EXISTS attribution (
  arm TEXT NOT NULL, cell TEXT NOT NULL, task INTEGER NOT NULL, seed INTEGER NOT NULL,
  config TEXT NOT NULL, layer INTEGER NOT NULL, name TEXT NOT NULL, harness INTEGER NOT NULL,
  capability TEXT NOT NULL, failure TEXT NOT NULL, stage TEXT NOT NULL, step INTEGER NOT NULL,
  PRIMARY KEY (arm, cell, task, seed, config));
)sql";

// Version 4: the simulator's own verdict beside the governor's (NULL: no report came), and the flag
// when they disagree, on every episode and every lost attempt. Version 5: the capabilities the arm needs
// that the episode ran without, comma-separated ('' none; NULL unknown: no result, or an older row).
struct AddedColumn {
  const char* name;
  const char* type;
};
constexpr AddedColumn kAddedColumns[] = {{"sim_success", "INTEGER"},
                                         {"sim_goal_step", "INTEGER NOT NULL DEFAULT -1"},
                                         {"sim_goal_at_end", "INTEGER NOT NULL DEFAULT 0"},
                                         {"verdict_disagrees", "INTEGER NOT NULL DEFAULT 0"},
                                         {"capabilities_missing", "TEXT"}};

// Column order shared by the insert and read_row(); a file older than version 5 opened read-only reads
// the columns it lacks as unknown.
#define DH_BASE_COLUMNS                                                                                    \
  "arm, cell, task, seed, success, steps, budget, wall_s, physics_s, outcome, reason, infrastructure, " \
  "tick_limit, evidence_path, episode_id, worker, channel, finished_at, "
constexpr const char* kColumns =
    DH_BASE_COLUMNS "sim_success, sim_goal_step, sim_goal_at_end, verdict_disagrees, capabilities_missing";
constexpr const char* kColumnsBeforeMissing =
    DH_BASE_COLUMNS "sim_success, sim_goal_step, sim_goal_at_end, verdict_disagrees, NULL";
constexpr const char* kColumnsBeforeVerdict = DH_BASE_COLUMNS "NULL, -1, 0, 0, NULL";
#undef DH_BASE_COLUMNS

// Clears a reused prepared statement whichever way the call leaves.
struct Reset {
  sqlite3_stmt* s;
  ~Reset() {
    sqlite3_reset(s);
    sqlite3_clear_bindings(s);
  }
};

void bind_arg(sqlite3_stmt* s, int i, const std::string& v) {
  sqlite3_bind_text(s, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
}
void bind_arg(sqlite3_stmt* s, int i, std::int64_t v) { sqlite3_bind_int64(s, i, v); }
void bind_arg(sqlite3_stmt* s, int i, double v) { sqlite3_bind_double(s, i, v); }

std::string column_text(sqlite3_stmt* s, int i) {
  const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(s, i));
  return p ? std::string(p, static_cast<std::size_t>(sqlite3_column_bytes(s, i))) : std::string();
}
unsigned column_uint(sqlite3_stmt* s, int i) { return static_cast<unsigned>(sqlite3_column_int64(s, i)); }

/// A stored list of names ('' none).
std::vector<std::string> names_of(const std::string& joined) {
  std::vector<std::string> out;
  if (!joined.empty())
    for (const auto name : split_commas(joined)) out.emplace_back(name);
  return out;
}

EpisodeRecord read_row(sqlite3_stmt* s) {
  EpisodeRecord r;
  r.arm = column_text(s, 0);
  r.cell = column_text(s, 1);
  r.task = column_uint(s, 2);
  r.seed = column_uint(s, 3);
  r.success = sqlite3_column_int(s, 4) != 0;
  r.steps = column_uint(s, 5);
  r.budget = column_uint(s, 6);
  r.wall_s = sqlite3_column_double(s, 7);
  r.physics_s = sqlite3_column_double(s, 8);
  r.outcome = column_text(s, 9);
  r.reason = column_text(s, 10);
  r.infrastructure = sqlite3_column_int(s, 11) != 0;
  r.tick_limit = sqlite3_column_int(s, 12) != 0;
  r.evidence_path = column_text(s, 13);
  r.episode_id = column_text(s, 14);
  r.worker = column_text(s, 15);
  r.channel = column_uint(s, 16);
  r.finished_at = column_text(s, 17);
  if (sqlite3_column_type(s, 18) != SQLITE_NULL) r.sim_success = sqlite3_column_int(s, 18) != 0;
  r.sim_goal_step = sqlite3_column_int(s, 19);
  r.sim_goal_at_end = sqlite3_column_int(s, 20) != 0;
  if (sqlite3_column_type(s, 22) != SQLITE_NULL) r.capabilities_missing = names_of(column_text(s, 22));
  return r;
}
}  // namespace

Key key_of(const EpisodeRecord& r) { return {r.arm, r.cell, r.task, r.seed}; }

void CampaignDb::Close::operator()(sqlite3* db) const { sqlite3_close_v2(db); }
void CampaignDb::Close::operator()(sqlite3_stmt* s) const { sqlite3_finalize(s); }

CampaignDb CampaignDb::open(const std::filesystem::path& path) { return CampaignDb(path, false); }

std::vector<EpisodeRecord> CampaignDb::read_rows(const std::filesystem::path& path) {
  return CampaignDb(path, true).rows();
}

std::vector<AttributionRow> CampaignDb::read_attributions(const std::filesystem::path& path, const std::string& config) {
  return CampaignDb(path, true).attributions(config);
}

CampaignDb::CampaignDb(std::filesystem::path path, bool read_only) : path_(std::move(path)) {
  if (read_only && !std::filesystem::exists(path_))
    throw CampaignError(path_.string() +
                        ": no such campaign database (check the path; `dh campaign --db` writes one)");
  if (!read_only && path_.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(path_.parent_path(), ec);
    if (ec)
      throw CampaignError(path_.string() + ": cannot create its folder (" + ec.message() +
                          "); choose a writable --db path");
  }
  sqlite3* raw = nullptr;
  const int flags = read_only ? SQLITE_OPEN_READONLY : SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE;
  const int rc = sqlite3_open_v2(path_.c_str(), &raw, flags, nullptr);
  db_.reset(raw);  // a handle comes back even when opening failed, and must be closed
  if (rc != SQLITE_OK) fail("cannot open it (check the path and its permissions)");
  sqlite3_extended_result_codes(db_.get(), 1);
  // Another process writing the same file holds the lock for one short transaction; wait for it.
  sqlite3_busy_timeout(db_.get(), kBusyTimeoutMs);
  check_or_create_schema(read_only);
  constexpr const char* kValues =
      ") VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) ";
  if (!read_only) {
    insert_ = prepare(("INSERT INTO episodes (" + std::string(kColumns) + kValues +
                       "ON CONFLICT (arm, cell, task, seed) DO NOTHING")
                          .c_str());
    insert_loss_ = prepare(("INSERT INTO infrastructure_losses (" + std::string(kColumns) + kValues +
                            "ON CONFLICT (episode_id) DO NOTHING")
                               .c_str());
  }
  has_ = prepare("SELECT 1 FROM episodes WHERE arm = ? AND cell = ? AND task = ? AND seed = ?");
  get_meta_ = prepare("SELECT value FROM meta WHERE key = ?");
  set_meta_ = prepare(
      "INSERT INTO meta (key, value) VALUES (?, ?) ON CONFLICT (key) DO UPDATE SET value = excluded.value");
}

void CampaignDb::fail(const std::string& what) const {
  const char* why = db_ ? sqlite3_errmsg(db_.get()) : "out of memory";
  throw CampaignError(path_.string() + ": " + what + ": " + why);
}

CampaignDb::Stmt CampaignDb::prepare(const char* sql) const {
  sqlite3_stmt* s = nullptr;
  if (sqlite3_prepare_v2(db_.get(), sql, -1, &s, nullptr) != SQLITE_OK)
    fail(std::string("cannot prepare ") + sql);
  return Stmt(s);
}

void CampaignDb::check_or_create_schema(bool read_only) {
  sqlite3* db = db_.get();
  const auto exec = [&](const char* sql) {
    if (sqlite3_exec(db, sql, nullptr, nullptr, nullptr) != SQLITE_OK) fail(std::string("cannot run ") + sql);
  };
  // SQLite reads the header lazily: the first statement tells whether this is a database at all.
  const int probe = sqlite3_exec(db, "SELECT count(*) FROM sqlite_master", nullptr, nullptr, nullptr);
  if ((probe & 0xff) == SQLITE_NOTADB)
    throw CampaignError(
        path_.string() +
        ": not a SQLite database, so not a campaign database; give --db another file or move this one away");
  if (probe != SQLITE_OK) fail("cannot read it");

  // IMMEDIATE: two processes creating the same new file take turns, and the second finds the schema.
  if (!read_only) exec("BEGIN IMMEDIATE");
  std::set<std::string> tables;
  {
    Stmt s = prepare("SELECT name FROM sqlite_master WHERE type = 'table'");
    while (sqlite3_step(s.get()) == SQLITE_ROW) tables.insert(column_text(s.get(), 0));
  }
  if (tables.empty() && !read_only) {
    exec(kSchema);
    exec(kLossesTable);
    exec(kAttributionTable);
    add_columns();
    exec(("INSERT INTO meta (key, value) VALUES ('schema_version', '" + std::to_string(kSchemaVersion) + "')")
             .c_str());
  } else {
    std::string version;
    if (tables.count("meta") && tables.count("episodes")) {
      Stmt s = prepare("SELECT value FROM meta WHERE key = 'schema_version'");
      if (sqlite3_step(s.get()) == SQLITE_ROW) version = column_text(s.get(), 0);
    }
    if (version.empty())
      throw CampaignError(
          path_.string() +
          ": a SQLite database but not a campaign database (no meta.schema_version); give --db another file");
    const bool known = version == "1" || version == "2" || version == "3" || version == "4" ||
                       version == std::to_string(kSchemaVersion);
    if (!known)
      throw CampaignError(path_.string() + ": campaign database schema version " + version +
                          ", this build reads " + std::to_string(kSchemaVersion) +
                          "; give --db a new file or read it with the dh build that wrote it");
    if (version != std::to_string(kSchemaVersion) && !read_only) {  // older versions lack tables and columns
      if (version == "1") exec(kLossesTable);
      exec(kAttributionTable);
      add_columns();
      exec(("UPDATE meta SET value = '" + std::to_string(kSchemaVersion) + "' WHERE key = 'schema_version'").c_str());
    } else if (read_only) {
      version_ = std::stoi(version);
    }
  }
  if (read_only) return;
  exec("COMMIT");
  exec("PRAGMA journal_mode = WAL");
  // FULL: in WAL mode, NORMAL may lose the last commits on power loss (WAL not yet synced); FULL syncs
  // the WAL on every commit, so a recorded episode is never run again. One fsync per episode is nothing
  // next to an episode's seconds of simulation.
  exec("PRAGMA synchronous = FULL");
}

namespace {
void bind_record(sqlite3_stmt* s, const EpisodeRecord& r) {
  if (r.sim_success)
    bind_arg(s, 19, std::int64_t{*r.sim_success});
  else
    sqlite3_bind_null(s, 19);
  bind_arg(s, 20, std::int64_t{r.sim_goal_step});
  bind_arg(s, 21, std::int64_t{r.sim_goal_at_end});
  bind_arg(s, 22, std::int64_t{r.verdict_disagrees()});
  if (r.capabilities_missing)
    bind_arg(s, 23, join_commas(*r.capabilities_missing));
  else
    sqlite3_bind_null(s, 23);
  const auto i64 = [](unsigned v) { return static_cast<std::int64_t>(v); };
  bind_arg(s, 1, r.arm);
  bind_arg(s, 2, r.cell);
  bind_arg(s, 3, i64(r.task));
  bind_arg(s, 4, i64(r.seed));
  bind_arg(s, 5, std::int64_t{r.success});
  bind_arg(s, 6, i64(r.steps));
  bind_arg(s, 7, i64(r.budget));
  bind_arg(s, 8, r.wall_s);
  bind_arg(s, 9, r.physics_s);
  bind_arg(s, 10, r.outcome);
  bind_arg(s, 11, r.reason);
  bind_arg(s, 12, std::int64_t{r.infrastructure});
  bind_arg(s, 13, std::int64_t{r.tick_limit});
  bind_arg(s, 14, r.evidence_path);
  bind_arg(s, 15, r.episode_id);
  bind_arg(s, 16, r.worker);
  bind_arg(s, 17, i64(r.channel));
  bind_arg(s, 18, r.finished_at);
}
}  // namespace

bool CampaignDb::record(const EpisodeRecord& r) {
  sqlite3_stmt* s = insert_.get();
  Reset reset{s};
  bind_record(s, r);
  // One statement outside BEGIN is one transaction of its own, committed (and synced) before step returns.
  if (sqlite3_step(s) != SQLITE_DONE) fail("cannot record episode " + to_string(key_of(r)));
  return sqlite3_changes(db_.get()) == 1;
}

bool CampaignDb::record_loss(const EpisodeRecord& r) {
  sqlite3_stmt* s = insert_loss_.get();
  Reset reset{s};
  bind_record(s, r);
  if (sqlite3_step(s) != SQLITE_DONE) fail("cannot record the infrastructure loss of " + r.episode_id);
  return sqlite3_changes(db_.get()) == 1;
}

bool CampaignDb::has(const std::string& arm, const std::string& cell, unsigned task, unsigned seed) const {
  sqlite3_stmt* s = has_.get();
  Reset reset{s};
  bind_arg(s, 1, arm);
  bind_arg(s, 2, cell);
  bind_arg(s, 3, std::int64_t{task});
  bind_arg(s, 4, std::int64_t{seed});
  const int rc = sqlite3_step(s);
  if (rc != SQLITE_ROW && rc != SQLITE_DONE) fail("cannot look up an episode");
  return rc == SQLITE_ROW;
}

std::set<Key> CampaignDb::finished() const {
  Stmt s = prepare("SELECT arm, cell, task, seed FROM episodes");
  std::set<Key> out;
  int rc;
  while ((rc = sqlite3_step(s.get())) == SQLITE_ROW)
    out.insert(
        {column_text(s.get(), 0), column_text(s.get(), 1), column_uint(s.get(), 2), column_uint(s.get(), 3)});
  if (rc != SQLITE_DONE) fail("cannot read the finished episodes");
  return out;
}

std::vector<EpisodeRecord> CampaignDb::rows() const {
  Stmt s =
      prepare(("SELECT " + std::string(columns()) + " FROM episodes ORDER BY arm, cell, task, seed").c_str());
  std::vector<EpisodeRecord> out;
  int rc;
  while ((rc = sqlite3_step(s.get())) == SQLITE_ROW) out.push_back(read_row(s.get()));
  if (rc != SQLITE_DONE) fail("cannot read the episodes");
  return out;
}

std::vector<EpisodeRecord> CampaignDb::losses() const {
  bool exists = false;
  {
    Stmt t = prepare("SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'infrastructure_losses'");
    exists = sqlite3_step(t.get()) == SQLITE_ROW;
  }
  if (!exists) return {};  // a version-1 file opened read-only
  Stmt s = prepare(
      ("SELECT " + std::string(columns()) + " FROM infrastructure_losses ORDER BY finished_at, episode_id").c_str());
  std::vector<EpisodeRecord> out;
  int rc;
  while ((rc = sqlite3_step(s.get())) == SQLITE_ROW) out.push_back(read_row(s.get()));
  if (rc != SQLITE_DONE) fail("cannot read the infrastructure losses");
  return out;
}

void CampaignDb::add_columns() {
  for (const char* table : {"episodes", "infrastructure_losses"})
    for (const AddedColumn& c : kAddedColumns) {
      sqlite3_stmt* probe = nullptr;
      const std::string select = "SELECT " + std::string(c.name) + " FROM " + table + " LIMIT 0";
      const bool present = sqlite3_prepare_v2(db_.get(), select.c_str(), -1, &probe, nullptr) == SQLITE_OK;
      sqlite3_finalize(probe);
      if (!present) run_sql(("ALTER TABLE " + std::string(table) + " ADD COLUMN " + c.name + " " + c.type).c_str());
    }
}

const char* CampaignDb::columns() const {
  return version_ >= 5 ? kColumns : version_ == 4 ? kColumnsBeforeMissing : kColumnsBeforeVerdict;
}

void CampaignDb::run_sql(const char* sql) {
  if (sqlite3_exec(db_.get(), sql, nullptr, nullptr, nullptr) != SQLITE_OK) fail(std::string("cannot run ") + sql);
}

void CampaignDb::replace_attributions(const std::string& config, const std::vector<AttributionRow>& rows) {
  run_sql("BEGIN IMMEDIATE");
  try {
    Stmt clear = prepare("DELETE FROM attribution WHERE config = ?");
    bind_arg(clear.get(), 1, config);
    if (sqlite3_step(clear.get()) != SQLITE_DONE) fail("cannot clear the attributions of " + config);
    Stmt s = prepare(
        "INSERT OR REPLACE INTO attribution (arm, cell, task, seed, config, layer, name, harness, capability, "
        "failure, stage, step) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
    for (const AttributionRow& a : rows) {
      Reset reset{s.get()};
      if (a.config != config) throw std::invalid_argument("replace_attributions: a row of " + a.config + " among " + config);
      bind_arg(s.get(), 1, a.arm);
      bind_arg(s.get(), 2, a.cell);
      bind_arg(s.get(), 3, std::int64_t{a.task});
      bind_arg(s.get(), 4, std::int64_t{a.seed});
      bind_arg(s.get(), 5, a.config);
      bind_arg(s.get(), 6, std::int64_t{a.layer});
      bind_arg(s.get(), 7, a.name);
      bind_arg(s.get(), 8, std::int64_t{a.harness});
      bind_arg(s.get(), 9, a.capability);
      bind_arg(s.get(), 10, a.failure);
      bind_arg(s.get(), 11, a.stage);
      bind_arg(s.get(), 12, std::int64_t{a.step});
      if (sqlite3_step(s.get()) != SQLITE_DONE)
        fail("cannot record the attribution of " + a.arm + " " + a.cell + "/" + std::to_string(a.task) + " seed " +
             std::to_string(a.seed));
    }
  } catch (...) {
    run_sql("ROLLBACK");
    throw;
  }
  run_sql("COMMIT");
}

std::vector<AttributionRow> CampaignDb::attributions(const std::string& config) const {
  bool exists = false;
  {
    Stmt t = prepare("SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'attribution'");
    exists = sqlite3_step(t.get()) == SQLITE_ROW;
  }
  if (!exists) return {};  // an older file opened read-only
  Stmt s = prepare(
      "SELECT arm, cell, task, seed, config, layer, name, harness, capability, failure, stage, step FROM attribution "
      "WHERE config = ? ORDER BY arm, cell, task, seed");
  bind_arg(s.get(), 1, config);
  std::vector<AttributionRow> out;
  int rc;
  while ((rc = sqlite3_step(s.get())) == SQLITE_ROW) {
    sqlite3_stmt* r = s.get();
    out.push_back({column_text(r, 0), column_text(r, 1), column_uint(r, 2), column_uint(r, 3), column_text(r, 4),
                   static_cast<int>(sqlite3_column_int64(r, 5)), column_text(r, 6), sqlite3_column_int64(r, 7) != 0,
                   column_text(r, 8), column_text(r, 9), column_text(r, 10), column_uint(r, 11)});
  }
  if (rc != SQLITE_DONE) fail("cannot read the attributions");
  return out;
}

std::size_t CampaignDb::count() const {
  Stmt s = prepare("SELECT count(*) FROM episodes");
  if (sqlite3_step(s.get()) != SQLITE_ROW) fail("cannot count the episodes");
  return static_cast<std::size_t>(sqlite3_column_int64(s.get(), 0));
}

void CampaignDb::set_meta(const std::string& key, const std::string& value) {
  sqlite3_stmt* s = set_meta_.get();
  Reset reset{s};
  bind_arg(s, 1, key);
  bind_arg(s, 2, value);
  if (sqlite3_step(s) != SQLITE_DONE) fail("cannot set meta '" + key + "'");
}

std::optional<std::string> CampaignDb::meta(const std::string& key) const {
  sqlite3_stmt* s = get_meta_.get();
  Reset reset{s};
  bind_arg(s, 1, key);
  const int rc = sqlite3_step(s);
  if (rc == SQLITE_ROW) return column_text(s, 0);
  if (rc != SQLITE_DONE) fail("cannot read meta '" + key + "'");
  return std::nullopt;
}

std::vector<std::string> CampaignDb::declare_plan(const Plan& requested) {
  // Insert-if-absent, then compare: two processes declaring at once agree on whichever plan came first.
  Stmt s = prepare("INSERT INTO meta (key, value) VALUES ('plan', ?) ON CONFLICT (key) DO NOTHING");
  bind_arg(s.get(), 1, to_json(requested));
  if (sqlite3_step(s.get()) != SQLITE_DONE) fail("cannot store the plan");
  if (sqlite3_changes(db_.get()) == 1) return {};
  return plan_differences(*plan(), requested);
}

std::optional<Plan> CampaignDb::plan() const {
  const auto json = meta("plan");
  if (!json) return std::nullopt;
  try {
    return plan_from_json(*json);
  } catch (const PlanError& e) {
    throw CampaignError(path_.string() + ": " + e.what());
  }
}

}  // namespace dh::campaign
