// A campaign's plan (arms × cells × tasks × seeds) and its expansion into episodes, in the order they run.
#pragma once

#include <compare>
#include <cstdint>
#include <functional>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace dh::campaign {

/// Bad user input or a malformed stored plan; the message names the option and the offending token.
struct PlanError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// One episode of a campaign. Ordered by arm, cell, task, seed.
struct EpisodeKey {
  std::string arm;
  std::string cell;
  unsigned task = 0;
  unsigned seed = 0;
  auto operator<=>(const EpisodeKey&) const = default;
};
std::string to_string(const EpisodeKey& k);  ///< "arm/cell/task/seed"

struct Plan {
  std::vector<std::string> arms, cells;
  std::vector<unsigned> tasks;  ///< empty = every task of each cell
  std::vector<unsigned> seeds;
  std::string rerun_rule;  ///< declared before the run, e.g. "none" or "infrastructure once"
  std::string library_version{};  ///< the capability library every episode runs (cap::library_version)
  std::string planner_errors{};   ///< the planner-error profile every episode runs under; empty: none
  std::string verifier = "oracle";  ///< the verdict every episode ends on: oracle | perception
  std::string robot{};  ///< the arm on every scene's mount (a robot profile); empty: the scenes' own
  bool operator==(const Plan&) const = default;
};

/// "a,b,c" → {"a","b","c"} (items trimmed). Rejects an empty list, an empty item and a repeated item.
std::vector<std::string> parse_list(std::string_view text, std::string_view option);

/// "1,3,5-7" → {1,3,5,6,7}, ranges inclusive, order kept. Rejects "", non-numbers, "5-3", values above
/// 2^32-1, more than 10^6 numbers and a number given twice (naming both tokens that gave it).
std::vector<unsigned> parse_numbers(std::string_view text, std::string_view option);
inline std::vector<unsigned> parse_seeds(std::string_view text) { return parse_numbers(text, "--seeds"); }

/// The plan as one JSON object (the form stored in the campaign database) and back; PlanError if malformed.
std::string to_json(const Plan& p);
Plan plan_from_json(const std::string& json);

/// What differs between the plan stored with a campaign and the one asked for now, one line per field
/// ("seeds: stored 1-20, requested 1-40"); empty = the same campaign. Lists compare as sets: their order
/// changes only the schedule, not which episodes belong to the campaign.
std::vector<std::string> plan_differences(const Plan& stored, const Plan& requested);

/// Every episode of the plan, seed-major: for each seed, each cell, each task, every arm in turn.
/// Arms of one (cell, task, seed) are adjacent, so they run at the same time on neighbouring channels and
/// a campaign cut short leaves complete pairs; seeds outermost make the finished prefix a balanced sample
/// (every cell and task with the same seeds) instead of whole cells done and others missing.
/// `tasks_of_cell` lists a cell's tasks; plan.tasks, when given, must be among them (PlanError otherwise).
std::vector<EpisodeKey> expand(
    const Plan& plan, const std::function<std::vector<unsigned>(const std::string& cell)>& tasks_of_cell);

/// The episodes of `all` not yet in `finished`, in the order of `all`.
std::vector<EpisodeKey> remaining(const std::vector<EpisodeKey>& all, const std::set<EpisodeKey>& finished);

/// `count` distinct seeds ≥ 10^6 (development seeds stay below), for tests on states nobody tuned on.
/// Rule: splitmix64 started at `salt`; each draw x gives the seed 10^6 + x mod (2^32 − 10^6); a seed already
/// drawn is skipped. The block for (n, salt) is the first n of the block for (n + k, salt), so a block can
/// be extended without changing the seeds already run. count ≤ 10^6 (PlanError otherwise).
std::vector<unsigned> fresh_seed_block(unsigned count, std::uint64_t salt);

}  // namespace dh::campaign
