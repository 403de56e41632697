// Where the project's files are, without any machine's absolute path in the repo.
//
// DH_HOME          the checkout root (default: found upwards from the running executable)
// DH_CONFIG_DIR    configs/ (default: $DH_HOME/configs)
// DH_DDS_PROFILE   Fast DDS XML profile (default: $DH_HOME/deploy/dds/loopback.xml)
// DH_RUNS_DIR      where evidence and results go (default: ./runs in the working directory)
#pragma once

#include <filesystem>
#include <string>

namespace dh::paths {

std::filesystem::path self_exe();
std::filesystem::path bin_dir();  ///< the folder of the running executable (build/bin)
std::filesystem::path home();     ///< throws ConfigError when no checkout can be found
std::filesystem::path config_dir();
std::filesystem::path dds_profile();
std::filesystem::path runs_dir();
/// An episode's evidence file under `runs`/evidence: the episode id made safe for a file name, then
/// `extension` (".jsonl": the governor's records; ".steps": the seam's step log beside it).
std::filesystem::path evidence_file(const std::filesystem::path& runs, const std::string& episode_id,
                                    const char* extension);

}  // namespace dh::paths
