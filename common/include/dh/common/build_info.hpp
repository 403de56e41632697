// The build a process runs: recorded with every episode (a fingerprint `dh replay` compares).
#pragma once

#include <string>

namespace dh {

struct BuildInfo {
  std::string commit;  ///< git commit of the source tree, "unknown" outside a checkout
  std::string dirty;   ///< empty for a clean tree, else the SHA-1 of `git diff HEAD` and the untracked files
  /// "<commit>" or "<commit>+dirty.<first 12 of the diff's hash>".
  std::string str() const { return dirty.empty() ? commit : commit + "+dirty." + dirty.substr(0, 12); }
};

const BuildInfo& build_info();

}  // namespace dh
