// Benchmark suites and tasks, from configs/suites/*.yaml.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace dh {

/// A goal predicate, e.g. On(bowl, plate).
struct PredicateSpec {
  std::string name;
  std::vector<std::string> args;
  std::string text() const;
};

struct TaskDef {
  std::string suite;
  unsigned id = 0;
  std::string instruction;
  unsigned budget_steps = 0;
  std::filesystem::path scene_file;  ///< absolute, resolved relative to the suite file
  std::vector<PredicateSpec> goal;   ///< conjunction
};

struct SuiteDef {
  std::string name;
  std::string modelled_on;
  unsigned budget_steps = 0;
  std::map<unsigned, TaskDef> tasks;
};

/// Loads every configs/suites/*.yaml under `config_dir`; throws ConfigError naming file and key.
std::map<std::string, SuiteDef> load_suites(const std::filesystem::path& config_dir);

/// The task, or ConfigError saying which suites/tasks exist.
const TaskDef& find_task(const std::map<std::string, SuiteDef>& suites, const std::string& suite,
                         unsigned task);

}  // namespace dh
