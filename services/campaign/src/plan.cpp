#include "dh/campaign/plan.hpp"

#include <algorithm>
#include <charconv>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <unordered_set>

#include "comma_list.hpp"

namespace dh::campaign {

namespace {
constexpr std::size_t kMaxNumbers = 1'000'000;
constexpr std::uint64_t kFirstFreshSeed = 1'000'000;

[[noreturn]] void fail(std::string_view option, const std::string& what) {
  throw PlanError(std::string(option) + ": " + what);
}

unsigned parse_number(std::string_view s, std::string_view token, std::string_view option) {
  std::uint64_t v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || end != s.data() + s.size())
    fail(option, "'" + std::string(token) + "' is not a non-negative integer or a range like 1-20");
  if (ec == std::errc::result_out_of_range || v > std::numeric_limits<unsigned>::max())
    fail(option,
         "'" + std::string(token) + "' is above " + std::to_string(std::numeric_limits<unsigned>::max()));
  return static_cast<unsigned>(v);
}

// {1,2,3,7} → "1-3,7"
std::string compact(std::vector<unsigned> v) {
  std::sort(v.begin(), v.end());
  std::string out;
  for (std::size_t i = 0; i < v.size();) {
    std::size_t j = i;
    while (j + 1 < v.size() && v[j + 1] == v[j] + 1) ++j;
    if (!out.empty()) out += ',';
    out += std::to_string(v[i]);
    if (j > i) out += '-' + std::to_string(v[j]);
    i = j + 1;
  }
  return out;
}

std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}
}  // namespace

std::string to_string(const EpisodeKey& k) {
  return k.arm + "/" + k.cell + "/" + std::to_string(k.task) + "/" + std::to_string(k.seed);
}

std::vector<std::string> parse_list(std::string_view text, std::string_view option) {
  if (trim(text).empty()) fail(option, "nothing given (expected e.g. a,b)");
  std::vector<std::string> out;
  for (const auto item : split_commas(text)) {
    if (item.empty()) fail(option, "empty item in '" + std::string(text) + "'");
    if (std::find(out.begin(), out.end(), item) != out.end())
      fail(option, "'" + std::string(item) + "' is given twice");
    out.emplace_back(item);
  }
  return out;
}

std::vector<unsigned> parse_numbers(std::string_view text, std::string_view option) {
  if (trim(text).empty()) fail(option, "nothing given (expected e.g. 1-20 or 1,3,5-7)");
  std::vector<unsigned> out;
  std::map<unsigned, std::string_view> given_by;
  for (const auto token : split_commas(text)) {
    if (token.empty()) fail(option, "empty item in '" + std::string(text) + "'");
    const std::size_t dash = token.find('-');
    const unsigned lo = parse_number(trim(token.substr(0, dash)), token, option);
    const unsigned hi =
        dash == std::string_view::npos ? lo : parse_number(trim(token.substr(dash + 1)), token, option);
    if (hi < lo)
      fail(option, "'" + std::string(token) + "' is a descending range (write " + std::to_string(hi) + "-" +
                       std::to_string(lo) + ")");
    if (out.size() + (std::uint64_t{hi} - lo + 1) > kMaxNumbers)
      fail(option,
           "'" + std::string(token) + "' makes more than " + std::to_string(kMaxNumbers) + " numbers");
    for (std::uint64_t v = lo; v <= hi; ++v) {
      const auto [it, fresh] = given_by.emplace(static_cast<unsigned>(v), token);
      if (!fresh)
        fail(option, std::to_string(v) + " is given twice ('" + std::string(it->second) + "' and '" +
                         std::string(token) + "')");
      out.push_back(static_cast<unsigned>(v));
    }
  }
  return out;
}

std::string to_json(const Plan& p) {
  return nlohmann::json{{"arms", p.arms},
                        {"cells", p.cells},
                        {"tasks", p.tasks},
                        {"seeds", p.seeds},
                        {"rerun_rule", p.rerun_rule},
                        {"library_version", p.library_version},
                        {"planner_errors", p.planner_errors},
                        {"verifier", p.verifier},
                        {"robot", p.robot}}
      .dump();
}

Plan plan_from_json(const std::string& json) {
  try {
    const auto j = nlohmann::json::parse(json);
    Plan p;
    j.at("arms").get_to(p.arms);
    j.at("cells").get_to(p.cells);
    j.at("tasks").get_to(p.tasks);
    j.at("seeds").get_to(p.seeds);
    j.at("rerun_rule").get_to(p.rerun_rule);
    p.library_version = j.value("library_version", "");  // not stored before the library travelled
    p.planner_errors = j.value("planner_errors", "");    // not stored before planner errors existed
    p.verifier = j.value("verifier", "oracle");           // not stored before the verdict from perception
    p.robot = j.value("robot", "");                       // not stored before --robot
    return p;
  } catch (const nlohmann::json::exception& e) {
    throw PlanError(std::string("stored plan is malformed (") + e.what() + "): " + json);
  }
}

std::vector<std::string> plan_differences(const Plan& stored, const Plan& requested) {
  std::vector<std::string> out;
  const auto names = [&](const char* field, const std::vector<std::string>& a,
                         const std::vector<std::string>& b) {
    const std::set<std::string> sa(a.begin(), a.end()), sb(b.begin(), b.end());
    if (sa != sb)
      out.push_back(std::string(field) + ": stored " + join_commas(sa) + ", requested " + join_commas(sb));
  };
  const auto numbers = [&](const char* field, const std::vector<unsigned>& a,
                           const std::vector<unsigned>& b) {
    if (std::set<unsigned>(a.begin(), a.end()) == std::set<unsigned>(b.begin(), b.end())) return;
    const auto text = [](const std::vector<unsigned>& v) {
      return v.empty() ? std::string("every") : compact(v);
    };
    out.push_back(std::string(field) + ": stored " + text(a) + ", requested " + text(b));
  };
  names("arms", stored.arms, requested.arms);
  names("cells", stored.cells, requested.cells);
  numbers("tasks", stored.tasks, requested.tasks);
  numbers("seeds", stored.seeds, requested.seeds);
  if (stored.rerun_rule != requested.rerun_rule)
    out.push_back("rerun rule: stored '" + stored.rerun_rule + "', requested '" + requested.rerun_rule + "'");
  if (!stored.library_version.empty() && stored.library_version != requested.library_version)
    out.push_back("library: stored " + stored.library_version + ", requested " + requested.library_version);
  if (stored.planner_errors != requested.planner_errors)
    out.push_back("planner errors: stored '" + stored.planner_errors + "', requested '" + requested.planner_errors + "'");
  if (stored.verifier != requested.verifier)
    out.push_back("verifier: stored '" + stored.verifier + "', requested '" + requested.verifier + "'");
  if (stored.robot != requested.robot)
    out.push_back("robot: stored '" + (stored.robot.empty() ? "the scenes' own" : stored.robot) + "', requested '" +
                  (requested.robot.empty() ? "the scenes' own" : requested.robot) + "'");
  return out;
}

std::vector<EpisodeKey> expand(
    const Plan& plan, const std::function<std::vector<unsigned>(const std::string& cell)>& tasks_of_cell) {
  std::vector<std::vector<unsigned>> tasks;  // per cell, in plan.cells order
  for (const auto& cell : plan.cells) {
    const auto known = tasks_of_cell(cell);
    for (unsigned t : plan.tasks)
      if (std::find(known.begin(), known.end(), t) == known.end())
        fail("--tasks", "task " + std::to_string(t) + " is not in cell '" + cell +
                            "' (its tasks: " + compact(known) + ")");
    tasks.push_back(plan.tasks.empty() ? known : plan.tasks);
  }
  std::vector<EpisodeKey> out;
  for (unsigned seed : plan.seeds)
    for (std::size_t c = 0; c < plan.cells.size(); ++c)
      for (unsigned task : tasks[c])
        for (const auto& arm : plan.arms) out.push_back({arm, plan.cells[c], task, seed});
  return out;
}

std::vector<EpisodeKey> remaining(const std::vector<EpisodeKey>& all, const std::set<EpisodeKey>& finished) {
  std::vector<EpisodeKey> out;
  std::copy_if(all.begin(), all.end(), std::back_inserter(out),
               [&](const auto& k) { return !finished.count(k); });
  return out;
}

std::vector<unsigned> fresh_seed_block(unsigned count, std::uint64_t salt) {
  if (count > kMaxNumbers)
    fail("--fresh-seeds", "'" + std::to_string(count) + "' is more than " + std::to_string(kMaxNumbers));
  constexpr std::uint64_t span = (std::uint64_t{1} << 32) - kFirstFreshSeed;
  std::vector<unsigned> out;
  std::unordered_set<unsigned> drawn;
  std::uint64_t state = salt;
  while (out.size() < count) {
    const auto seed = static_cast<unsigned>(kFirstFreshSeed + splitmix64(state) % span);
    if (drawn.insert(seed).second) out.push_back(seed);
  }
  return out;
}

}  // namespace dh::campaign
