#include "dh/policy/features.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>

namespace dh::policy {

StepRecord record(const Observation& obs, double gripper_command) {
  StepRecord r;
  r.gripper_command = static_cast<float>(gripper_command);
  r.proprio = {static_cast<float>(obs.ee_p[0]), static_cast<float>(obs.ee_p[1]), static_cast<float>(obs.ee_p[2]),
               static_cast<float>(obs.ee_q[0]), static_cast<float>(obs.ee_q[1]), static_cast<float>(obs.ee_q[2]),
               static_cast<float>(obs.ee_q[3]), static_cast<float>(obs.gripper_opening),
               obs.contact_left ? 1.f : 0.f,        obs.contact_right ? 1.f : 0.f};
  r.entities.reserve(obs.entities.size() * 4);
  for (const auto& e : obs.entities) {
    for (double v : e.p) r.entities.push_back(static_cast<float>(v));
    r.entities.push_back(static_cast<float>(e.joint));
  }
  return r;
}

std::vector<std::string> entity_names(const Observation& obs) {
  std::vector<std::string> n;
  for (const auto& e : obs.entities) n.push_back(e.name);
  return n;
}

std::vector<std::string> words_of(const std::string& instruction) {
  std::vector<std::string> w;
  std::string cur;
  for (char c : instruction + " ") {
    if (std::isalnum(static_cast<unsigned char>(c))) {
      cur += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    } else if (!cur.empty()) {
      w.push_back(cur);
      cur.clear();
    }
  }
  return w;
}

std::vector<int> FeatureSpec::slots(const std::vector<std::string>& names) const {
  std::vector<int> s;
  for (const auto& n : names) {
    const auto it = std::find(entities.begin(), entities.end(), n);
    s.push_back(it == entities.end() ? -1 : static_cast<int>(it - entities.begin()));
  }
  return s;
}

std::vector<int> FeatureSpec::word_indices(const std::string& instruction) const {
  std::vector<int> idx;
  for (const auto& w : words_of(instruction)) {
    const auto it = std::find(words.begin(), words.end(), w);
    if (it != words.end()) idx.push_back(static_cast<int>(it - words.begin()));
  }
  return idx;
}

void encode(const FeatureSpec& spec, const StepRecord& r, const std::vector<int>& slots,
            const std::vector<int>& word_indices, float* out) {
  std::fill(out, out + spec.size(), 0.f);
  const float* p = r.proprio.data();
  // The tool's orientation as the first two columns of its rotation matrix: continuous, unlike a quaternion.
  const Eigen::Matrix3f rot = Eigen::Quaternionf(p[3], p[4], p[5], p[6]).normalized().toRotationMatrix();
  out[0] = p[0];
  out[1] = p[1];
  out[2] = p[2];
  for (int i = 0; i < 3; ++i) {
    out[3 + i] = rot(i, 0);
    out[6 + i] = rot(i, 1);
  }
  out[9] = p[7];
  out[10] = p[8];
  out[11] = p[9];
  out[12] = (p[8] > 0.5f && p[9] > 0.5f && p[7] > 0.002f) ? 1.f : 0.f;  // Observation::holding()
  out[13] = r.gripper_command;
  for (std::size_t i = 0; i < slots.size() && 4 * i + 3 < r.entities.size(); ++i) {
    if (slots[i] < 0) continue;
    float* e = out + FeatureSpec::kProprio + FeatureSpec::kPerEntity * slots[i];
    const float* v = r.entities.data() + 4 * i;
    e[0] = 1.f;
    for (int k = 0; k < 3; ++k) e[1 + k] = v[k] - p[k];
    e[4] = v[3];
  }
  float* bag = out + FeatureSpec::kProprio + FeatureSpec::kPerEntity * static_cast<int>(spec.entities.size());
  for (int w : word_indices) bag[w] = 1.f;
}

}  // namespace dh::policy
