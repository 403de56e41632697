#include "dh/common/suite.hpp"

#include <algorithm>
#include <functional>
#include <sstream>

#include "dh/common/config.hpp"

namespace dh {

std::string PredicateSpec::text() const {
  std::string s = name + "(";
  for (std::size_t i = 0; i < args.size(); ++i) s += (i ? ", " : "") + args[i];
  return s + ")";
}

std::string goal_text(const std::vector<PredicateSpec>& goal) {
  std::string s;
  for (const auto& p : goal) s += (s.empty() ? "" : " AND ") + p.text();
  return s;
}

std::string SwapSpec::text() const {
  std::string s;
  for (const auto& [a, b] : exchange) s += (s.empty() ? "" : ";") + a + "<->" + b;
  for (const auto& [e, xy] : moves) {
    std::ostringstream m;
    m << e << "->(" << xy[0] << "," << xy[1] << ")";
    s += (s.empty() ? "" : ";") + m.str();
  }
  return s;
}

std::string PosSpec::text() const {
  std::ostringstream s;
  s << "pos " << reach_m << " m x{";
  for (std::size_t i = 0; i < magnitudes.size(); ++i) s << (i ? "," : "") << magnitudes[i];
  s << "}";
  return s.str();
}

std::string ObjectSpec::text() const {
  std::ostringstream s;
  s << "object w[" << width[0] << "," << width[1] << "] h[" << height[0] << "," << height[1] << "] m[" << mass[0]
    << "," << mass[1] << "] shade " << shade << " instances " << instance_share << " {";
  bool first = true;
  for (const auto& [asset, others] : instances)
    for (const auto& o : others) {
      s << (first ? "" : ",") << asset << ">" << o;
      first = false;
    }
  s << "}";
  return s.str();
}

namespace {

std::vector<PredicateSpec> load_goal(const ConfigNode& n) {
  std::vector<PredicateSpec> goal;
  for (const ConfigNode& g : n.items("goal"))
    goal.push_back({g.get<std::string>("predicate"), g.get<std::vector<std::string>>("args")});
  if (goal.empty()) n.fail("goal", "a task needs at least one goal predicate");
  return goal;
}

SwapSpec load_swap(const ConfigNode& n) {
  SwapSpec swap;
  if (n.has("exchange"))
    for (const ConfigNode& pair : n.items("exchange")) {
      const auto names = pair.as<std::vector<std::string>>();
      if (names.size() != 2 || names[0] == names[1])
        n.fail("exchange", "each exchange is a pair of two different entity names");
      swap.exchange.push_back({names[0], names[1]});
    }
  if (n.has("move")) {
    const ConfigNode moves = n.child("move");
    for (const auto& name : moves.keys()) {
      const auto xy = moves.get<std::vector<double>>(name);
      if (xy.size() != 2) moves.fail(name, "expected the new nominal [x, y] (m)");
      swap.moves[name] = {xy[0], xy[1]};
    }
  }
  if (swap.empty()) n.fail("", "a swap perturbation needs an exchange or a move");
  return swap;
}

// The three cells of one suite file.
std::vector<SuiteDef> load_suite(const std::filesystem::path& file) {
  const ConfigNode root = ConfigNode::load_file(file);
  const std::string name = root.get<std::string>("suite");
  const std::string modelled_on = root.get_or<std::string>("modelled_on", "");
  const unsigned budget = root.get<unsigned>("budget_steps");
  const auto scenes = root.dir() / ".." / "scenes";
  auto scene_of = [&](const ConfigNode& n, const std::string& key) {
    const auto f = scenes / n.get<std::string>(key);
    if (!std::filesystem::exists(f)) n.fail(key, "scene file " + f.string() + " does not exist");
    return std::filesystem::weakly_canonical(f);
  };
  const auto default_scene = scene_of(root, "scene");
  std::vector<SuiteDef> cells(3);
  const char* kinds[3] = {"", "task", "swap"};
  for (int c = 0; c < 3; ++c) {
    cells[c].name = c == 0 ? name : name + "-" + kinds[c];
    cells[c].base_suite = name;
    cells[c].perturbation = kinds[c];
    cells[c].modelled_on = c == 0 ? modelled_on : modelled_on + " with LIBERO-Pro " + kinds[c] + " perturbation";
    cells[c].budget_steps = budget;
  }
  for (const ConfigNode& t : root.items("tasks")) {
    TaskDef task;
    task.base_suite = name;
    task.id = t.get<unsigned>("id");
    task.instruction = t.get<std::string>("instruction");
    task.budget_steps = t.get_or<unsigned>("budget_steps", budget);
    task.scene_file = t.has("scene") ? scene_of(t, "scene") : default_scene;
    task.goal = load_goal(t);
    TaskDef redirected = task;
    const ConfigNode tp = t.child("task");
    redirected.instruction = tp.get<std::string>("instruction");
    redirected.goal = load_goal(tp);
    if (redirected.instruction == task.instruction) tp.fail("instruction", "a task perturbation must redirect the instruction");
    TaskDef swapped = task;
    swapped.swap = load_swap(t.child("swap"));
    TaskDef* variants[3] = {&task, &redirected, &swapped};
    for (int c = 0; c < 3; ++c) {
      variants[c]->suite = cells[c].name;
      variants[c]->perturbation = kinds[c];
      if (!cells[c].tasks.emplace(task.id, *variants[c]).second)
        t.fail("id", "task " + std::to_string(task.id) + " is defined twice");
    }
  }
  return cells;
}

// A cell derived from `base` by `kind` ("lan", "pos", "object"): its tasks, renamed and marked, for the caller to
// perturb.
SuiteDef derived_cell(const SuiteDef& base, const std::string& kind, const std::string& description) {
  SuiteDef cell = base;
  cell.name = base.name + "-" + kind;
  cell.perturbation = kind;
  cell.modelled_on = base.modelled_on + " with LIBERO-Pro " + description + " perturbation";
  for (auto& [id, task] : cell.tasks) {
    task.suite = cell.name;
    task.perturbation = kind;
  }
  return cell;
}

// "<suite>-lan" cells: the base cell's tasks, each with its rewordings (every task must have some).
void load_wordings(const std::filesystem::path& file, std::map<std::string, SuiteDef>& suites) {
  const ConfigNode root = ConfigNode::load_file(file);
  const ConfigNode by_suite = root.child("suites");
  for (const std::string& base : by_suite.keys()) {
    const auto it = suites.find(base);
    if (it == suites.end()) by_suite.fail(base, "no suite '" + base + "' in configs/suites to reword");
    SuiteDef cell = derived_cell(it->second, "lan", "language");
    for (const ConfigNode& t : by_suite.items(base)) {
      const unsigned id = t.get<unsigned>("task");
      const auto task = cell.tasks.find(id);
      if (task == cell.tasks.end()) t.fail("task", "suite '" + base + "' has no task " + std::to_string(id));
      if (!task->second.wordings.empty()) t.fail("task", "task " + std::to_string(id) + " is reworded twice");
      task->second.wordings = t.get<std::vector<std::string>>("wordings");
      if (task->second.wordings.empty()) t.fail("wordings", "give at least one wording");
    }
    for (const auto& [id, task] : cell.tasks)
      if (task.wordings.empty())
        by_suite.fail(base, "task " + std::to_string(id) + " has no wordings: every task of a -lan cell needs some");
    suites.emplace(cell.name, std::move(cell));
  }
}

// A "<base>-<kind>" cell for each unperturbed suite the file's `suites` lists, each task perturbed by `perturb`.
void add_derived_cells(const ConfigNode& root, const std::string& kind, const std::string& description,
                       std::map<std::string, SuiteDef>& suites, const std::function<void(TaskDef&)>& perturb) {
  for (const std::string& base : root.get<std::vector<std::string>>("suites")) {
    const auto it = suites.find(base);
    if (it == suites.end() || !it->second.perturbation.empty())
      root.fail("suites", "no unperturbed suite '" + base + "' in configs/suites to derive a -" + kind + " cell from");
    SuiteDef cell = derived_cell(it->second, kind, description);
    for (auto& [id, task] : cell.tasks) perturb(task);
    suites.emplace(cell.name, std::move(cell));
  }
}

// "<suite>-pos" cells: the base cell's tasks, each object placed by the seed's magnitude.
void load_positions(const std::filesystem::path& file, std::map<std::string, SuiteDef>& suites) {
  const ConfigNode root = ConfigNode::load_file(file);
  PosSpec pos;
  pos.reach_m = root.get<double>("reach_m");
  if (!(pos.reach_m > 0 && pos.reach_m <= 1)) root.fail("reach_m", "give the displacement at magnitude 1, in (0, 1] m");
  pos.magnitudes = root.get<std::vector<double>>("magnitudes");
  if (pos.magnitudes.empty()) root.fail("magnitudes", "give at least one magnitude");
  for (const double m : pos.magnitudes)
    if (!(m > 0 && m <= 1)) root.fail("magnitudes", "each magnitude is in (0, 1], not " + std::to_string(m));
  add_derived_cells(root, "pos", "position", suites, [&](TaskDef& task) { task.pos = pos; });
}

// "<suite>-object" cells: the base cell's tasks, each object's attributes drawn per seed.
void load_objects(const std::filesystem::path& file, const std::filesystem::path& assets_dir,
                  std::map<std::string, SuiteDef>& suites) {
  const ConfigNode root = ConfigNode::load_file(file);
  ObjectSpec object;
  const auto range = [&](const char* key, double low, double high) {
    const auto r = root.get<std::vector<double>>(key);
    if (r.size() != 2 || !(r[0] >= low && r[0] <= r[1] && r[1] <= high))
      root.fail(key, "give [low, high] factors within [" + std::to_string(low) + ", " + std::to_string(high) + "]");
    return std::array<double, 2>{r[0], r[1]};
  };
  object.width = range("width", 0.5, 2.0);
  object.height = range("height", 0.5, 2.0);
  object.mass = range("mass", 0.2, 5.0);
  object.shade = root.get<double>("shade");
  if (!(object.shade >= 0 && object.shade < 0.5)) root.fail("shade", "give the colour channels' change, in [0, 0.5)");
  object.instance_share = root.get<double>("instance_share");
  if (!(object.instance_share >= 0 && object.instance_share <= 1)) root.fail("instance_share", "give a share in [0, 1]");
  const ConfigNode instances = root.child("instances");
  for (const std::string& asset : instances.keys()) {
    object.instances[asset] = instances.get<std::vector<std::string>>(asset);
    if (object.instances[asset].empty()) instances.fail(asset, "list at least one other instance, or remove the entry");
    for (const std::string& a : object.instances[asset])
      for (const std::string& name : {asset, a})
        if (!std::filesystem::exists(assets_dir / (name + ".yaml")))
          instances.fail(asset, "no asset '" + name + "' (" + (assets_dir / (name + ".yaml")).string() + " does not exist)");
  }
  add_derived_cells(root, "object", "object", suites, [&](TaskDef& task) { task.object = object; });
}

}  // namespace

const std::string& instruction_for(const TaskDef& task, std::uint64_t seed) {
  return task.wordings.empty() ? task.instruction : task.wordings[seed % task.wordings.size()];
}

std::map<std::string, SuiteDef> load_suites(const std::filesystem::path& config_dir) {
  const auto dir = config_dir / "suites";
  if (!std::filesystem::is_directory(dir))
    throw ConfigError(dir.string() + ": suites folder not found (set DH_CONFIG_DIR to configs/)");
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.path().extension() == ".yaml") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  std::map<std::string, SuiteDef> suites;
  for (const auto& f : files)
    for (SuiteDef& cell : load_suite(f)) {
      const std::string name = cell.name;
      if (!suites.emplace(name, std::move(cell)).second)
        throw ConfigError(f.string() + ": cell '" + name + "' is also defined by another suite file");
    }
  if (const auto wordings = dir / "lan" / "wordings.yaml"; std::filesystem::exists(wordings))
    load_wordings(wordings, suites);
  if (const auto positions = dir / "pos" / "positions.yaml"; std::filesystem::exists(positions))
    load_positions(positions, suites);
  if (const auto objects = dir / "object" / "objects.yaml"; std::filesystem::exists(objects))
    load_objects(objects, config_dir / "assets", suites);
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
