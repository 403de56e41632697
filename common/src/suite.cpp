#include "dh/common/suite.hpp"

#include <algorithm>

#include "dh/common/config.hpp"

namespace dh {

std::string PredicateSpec::text() const {
  std::string s = name + "(";
  for (std::size_t i = 0; i < args.size(); ++i) s += (i ? ", " : "") + args[i];
  return s + ")";
}

namespace {
SuiteDef load_suite(const std::filesystem::path& file) {
  const ConfigNode root = ConfigNode::load_file(file);
  SuiteDef suite;
  suite.name = root.get<std::string>("suite");
  suite.modelled_on = root.get_or<std::string>("modelled_on", "");
  suite.budget_steps = root.get<unsigned>("budget_steps");
  const std::filesystem::path scene = root.dir() / ".." / "scenes" / root.get<std::string>("scene");
  if (!std::filesystem::exists(scene))
    root.fail("scene", "scene file " + scene.string() + " does not exist");
  for (const ConfigNode& t : root.items("tasks")) {
    TaskDef task;
    task.suite = suite.name;
    task.id = t.get<unsigned>("id");
    task.instruction = t.get<std::string>("instruction");
    task.budget_steps = t.get_or<unsigned>("budget_steps", suite.budget_steps);
    task.scene_file = std::filesystem::weakly_canonical(scene);
    for (const ConfigNode& g : t.items("goal")) {
      PredicateSpec p{g.get<std::string>("predicate"), g.get<std::vector<std::string>>("args")};
      task.goal.push_back(std::move(p));
    }
    if (task.goal.empty()) t.fail("goal", "a task needs at least one goal predicate");
    if (!suite.tasks.emplace(task.id, task).second)
      t.fail("id", "task " + std::to_string(task.id) + " is defined twice");
  }
  return suite;
}
}  // namespace

std::map<std::string, SuiteDef> load_suites(const std::filesystem::path& config_dir) {
  const auto dir = config_dir / "suites";
  if (!std::filesystem::is_directory(dir))
    throw ConfigError(dir.string() + ": suites folder not found (set DH_CONFIG_DIR to configs/)");
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.path().extension() == ".yaml") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  std::map<std::string, SuiteDef> suites;
  for (const auto& f : files) {
    SuiteDef s = load_suite(f);
    std::string name = s.name;
    suites.emplace(name, std::move(s));
  }
  return suites;
}

const TaskDef& find_task(const std::map<std::string, SuiteDef>& suites, const std::string& suite,
                         unsigned task) {
  auto it = suites.find(suite);
  if (it == suites.end()) {
    std::string known;
    for (const auto& [name, _] : suites) known += (known.empty() ? "" : ", ") + name;
    throw ConfigError("unknown suite '" + suite + "' (known: " + known + ")");
  }
  auto t = it->second.tasks.find(task);
  if (t == it->second.tasks.end()) {
    std::string known;
    for (const auto& [id, _] : it->second.tasks) known += (known.empty() ? "" : ", ") + std::to_string(id);
    throw ConfigError("suite '" + suite + "' has no task " + std::to_string(task) +
                      " (tasks: " + known + "; see `dh tasks`)");
  }
  return t->second;
}

}  // namespace dh
