// The campaign database: one SQLite file (WAL) holding every finished episode of a campaign and its declared
// plan. Several processes may write the same file; each waits for the others' writes (busy_timeout).
#pragma once

#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "dh/campaign/plan.hpp"
#include "dh/common/episode_record.hpp"

struct sqlite3;
struct sqlite3_stmt;

namespace dh::campaign {

/// The file cannot be used as a campaign database; the message names the file and what to do.
struct CampaignError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

using Key = EpisodeKey;

/// A failed episode's attribution (dh attribute) under one attribution file, named by its content hash.
struct AttributionRow {
  std::string arm, cell;
  unsigned task = 0, seed = 0;
  std::string config;  ///< the attribution file's content hash
  int layer = -1;      ///< index of the layer, upstream = 0
  std::string name;
  bool harness = false;
  std::string capability, failure, stage;  ///< the failure signature ξ
  unsigned step = 0;
};
Key key_of(const EpisodeRecord& r);

/// One connection to a campaign database. Movable, not copyable; not to be shared between threads
/// (open one per thread or process: they coordinate through SQLite's locks).
class CampaignDb {
 public:
  /// 2 added infrastructure_losses, 3 attribution, 4 the simulator's verdict, 5 the capabilities an episode
  /// ran without; older are upgraded on open.
  static constexpr int kSchemaVersion = 5;
  static constexpr int kBusyTimeoutMs = 30'000;

  /// Opens `path` for reading and writing, creating its folders, the file and the schema when new.
  /// CampaignError if it is not a SQLite database, has another schema or version, or cannot be opened.
  static CampaignDb open(const std::filesystem::path& path);
  /// Every row of an existing campaign database, opened read-only (for reports); CampaignError naming
  /// the path when it is missing or not a campaign database.
  static std::vector<EpisodeRecord> read_rows(const std::filesystem::path& path);
  /// Its attributions under `config`, opened read-only (for reports); empty for a file that has none.
  static std::vector<AttributionRow> read_attributions(const std::filesystem::path& path, const std::string& config);

  /// Stores one finished episode, durable when this returns. A key already present keeps its first row:
  /// returns false and changes nothing (a resumed or duplicated run never counts an episode twice).
  bool record(const EpisodeRecord& r);
  /// Stores an attempt lost to infrastructure that the plan's rerun rule runs again (keyed by episode id;
  /// the episode's own row comes from its last attempt). False if that attempt is stored already.
  bool record_loss(const EpisodeRecord& r);
  /// Every attempt stored by record_loss, oldest first.
  std::vector<EpisodeRecord> losses() const;
  bool has(const std::string& arm, const std::string& cell, unsigned task, unsigned seed) const;
  std::set<Key> finished() const;
  std::vector<EpisodeRecord> rows() const;  ///< ordered by arm, cell, task, seed
  std::size_t count() const;

  /// Replaces every attribution stored under `config` by `rows` (each with that config), in one
  /// transaction: an episode no longer labelled loses its old label.
  void replace_attributions(const std::string& config, const std::vector<AttributionRow>& rows);
  /// The attributions stored under `config`, ordered by arm, cell, task, seed.
  std::vector<AttributionRow> attributions(const std::string& config) const;

  void set_meta(const std::string& key, const std::string& value);
  std::optional<std::string> meta(const std::string& key) const;

  /// Stores `requested` (meta key "plan") when the database has none and returns {}; otherwise returns
  /// plan_differences(stored, requested): empty = the same campaign, else one line per changed field.
  std::vector<std::string> declare_plan(const Plan& requested);
  std::optional<Plan> plan() const;

  const std::filesystem::path& path() const { return path_; }

 private:
  struct Close {
    void operator()(sqlite3* db) const;
    void operator()(sqlite3_stmt* s) const;
  };
  using Stmt = std::unique_ptr<sqlite3_stmt, Close>;

  CampaignDb(std::filesystem::path path, bool read_only);
  void check_or_create_schema(bool read_only);
  Stmt prepare(const char* sql) const;
  void run_sql(const char* sql);
  /// The columns of versions 4 (the simulator's verdict) and 5 (capabilities missing) on the episodes and
  /// losses tables, where missing.
  void add_columns();
  /// The episode columns in read_row()'s order, as this file has them.
  const char* columns() const;
  [[noreturn]] void fail(const std::string& what) const;

  std::filesystem::path path_;
  int version_ = kSchemaVersion;        ///< the file's schema version (older only when opened read-only)
  std::unique_ptr<sqlite3, Close> db_;  // declared before the statements: they are finalized first
  Stmt insert_, insert_loss_, has_, get_meta_, set_meta_;
};

}  // namespace dh::campaign
