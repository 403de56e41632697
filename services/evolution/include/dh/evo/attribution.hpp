// Attribution (the paper's Eq. 5 and Appendix A): a failed episode's label is the first of N ordered
// layers, upstream first, one of whose diagnostic checks holds on its evidence,
// A_N(E) = min{ j : d_j(E) = 1 }. The layers, their order, their checks and whether a failure there is
// the harness's (u_d counts those) are configuration (configs/attribution.yaml); the checks are named
// here, so a coarser N is another file, not other code. An episode no check matches is an error,
// never labelled silently. A check looks for its fault anywhere in the episode (the paper's d_j), not only
// at its end: a planner that fell silent once and was asked again still counts, upstream of the execution
// failure that ended the episode.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "dh/evo/facts.hpp"

namespace dh::evo {

struct Layer {
  std::string name;
  bool harness = true;              ///< a failure here is the harness's (counted by u_d)
  std::vector<std::string> checks;  ///< check names (check_names()); the layer matches if any holds
};

struct AttributionConfig {
  std::vector<Layer> layers;  ///< upstream first
};

/// The configuration's content hash ("attr-" + 16 hex digits of SHA-256 over the checks' version and the
/// layers, harness flags and checks in order; comments and formatting do not change it): labels are
/// stored under it.
std::string config_version(const AttributionConfig& config);

/// Every check a layer may name, with one line on what it looks for.
const std::vector<std::pair<std::string, std::string>>& check_names();

/// Loads an attribution file; throws ConfigError naming file and key (an unknown check lists the known
/// ones; no layers; a layer without checks; a name used twice).
AttributionConfig load_attribution(const std::filesystem::path& file);

/// ξ: where the failure sits.
struct Signature {
  std::string capability;  ///< the implicated command's capability ("" when no command ran)
  std::string failure;     ///< its failure code, or the refusal or missed wait that ended the episode
  std::string stage;
  std::uint32_t step = 0;
};

struct Attribution {
  int layer = -1;  ///< index into the configuration's layers, upstream = 0
  std::string name;
  bool harness = false;
  Signature signature;
};

/// The label of a failed episode; nullopt when no layer's check holds (the caller reports it as an
/// error). Throws std::invalid_argument for a successful episode (nothing to attribute).
std::optional<Attribution> attribute(const EpisodeFacts& facts, const AttributionConfig& config);

/// Whether the named check holds. Throws std::invalid_argument for an unknown name.
bool check(const std::string& name, const EpisodeFacts& facts);

}  // namespace dh::evo
