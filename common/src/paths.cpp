#include "dh/common/paths.hpp"

#include <cctype>
#include <cstdlib>

#include "dh/common/config.hpp"

namespace fs = std::filesystem;

namespace dh::paths {
namespace {
fs::path env_path(const char* name) {
  const char* v = std::getenv(name);
  return (v && *v) ? fs::path(v) : fs::path();
}
}  // namespace

fs::path self_exe() { return fs::canonical("/proc/self/exe"); }
fs::path bin_dir() { return self_exe().parent_path(); }

fs::path home() {
  if (fs::path p = env_path("DH_HOME"); !p.empty()) return p;
  for (fs::path dir = bin_dir(); !dir.empty(); dir = dir.parent_path()) {
    if (fs::exists(dir / "configs" / "suites") && fs::exists(dir / "deploy")) return dir;
    if (dir == dir.parent_path()) break;
  }
  throw ConfigError("cannot find the DynaHarness checkout above " + bin_dir().string() +
                    "; set DH_HOME to it");
}

fs::path config_dir() {
  if (fs::path p = env_path("DH_CONFIG_DIR"); !p.empty()) return p;
  return home() / "configs";
}

fs::path dds_profile() {
  if (fs::path p = env_path("DH_DDS_PROFILE"); !p.empty()) return p;
  return home() / "deploy" / "dds" / "loopback.xml";
}

fs::path runs_dir() {
  if (fs::path p = env_path("DH_RUNS_DIR"); !p.empty()) return p;
  return fs::current_path() / "runs";
}

fs::path evidence_file(const fs::path& runs, const std::string& episode_id, const char* extension) {
  std::string name = episode_id;
  for (char& ch : name)
    if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '-' && ch != '_' && ch != '.') ch = '_';
  return runs / "evidence" / (name + extension);
}

}  // namespace dh::paths
