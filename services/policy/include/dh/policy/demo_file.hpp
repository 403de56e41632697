// Demonstrations on disk, so the policy can be trained again (other hyper-parameters, another seed)
// without running the demonstrator again. Binary: a "DHDEMOS <format>" line, then the demonstrations.
#pragma once

#include <filesystem>
#include <vector>

#include "dh/policy/train.hpp"

namespace dh::policy {

/// Writes atomically (a temporary file renamed); throws PolicyFileError.
void save_demos(const std::vector<Demo>& demos, const std::filesystem::path& file);
/// Throws PolicyFileError naming the file and what is wrong (missing, foreign, truncated).
std::vector<Demo> load_demos(const std::filesystem::path& file);

}  // namespace dh::policy
