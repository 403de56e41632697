// What the embedded policy reads: the robot's proprioception and its last gripper command, every scene
// entity it was trained on (by name: presence, position relative to the tool, joint value) and the
// instruction as a bag of words. The vocabularies are fixed at training time and travel in the weight file, so training and
// serving encode through this one function.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "dh/common/observation.hpp"

namespace dh::policy {

/// One control step as the policy sees it, in the scene's own entity order (names kept per episode).
struct StepRecord {
  std::array<float, 10> proprio{};  ///< ee position (3), ee quaternion w,x,y,z (4), opening, contacts (2)
  float gripper_command = -1;       ///< the last gripper action (-1 open, +1 close)
  std::vector<float> entities;      ///< per entity: position (3), joint value
};

/// `gripper_command` is the gripper component of the action applied before this observation.
StepRecord record(const Observation& obs, double gripper_command);
std::vector<std::string> entity_names(const Observation& obs);

/// Lower-case words of an instruction (letters and digits; everything else separates).
std::vector<std::string> words_of(const std::string& instruction);

struct FeatureSpec {
  std::vector<std::string> entities;  ///< slot order
  std::vector<std::string> words;     ///< bag-of-words order

  static constexpr int kProprio = 14;
  static constexpr int kPerEntity = 5;
  int size() const { return kProprio + kPerEntity * static_cast<int>(entities.size()) + static_cast<int>(words.size()); }
  /// Slot of each of `names` (-1 for a name the policy never saw).
  std::vector<int> slots(const std::vector<std::string>& names) const;
  /// Bag-of-words index of each known word of `instruction`.
  std::vector<int> word_indices(const std::string& instruction) const;
};

/// Writes spec.size() floats: `slots` maps the record's entity order to the spec's slots.
void encode(const FeatureSpec& spec, const StepRecord& r, const std::vector<int>& slots,
            const std::vector<int>& word_indices, float* out);

}  // namespace dh::policy
