// θ's declared physical ranges: the shipped library declares one for every parameter and stays inside it;
// a missing, malformed or violated range and a parameter keyed to a case are refused with the file and key.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "dh/cap/library_theta.hpp"
#include "dh/cap/theta_ranges.hpp"
#include "dh/common/paths.hpp"

using namespace dh;
using namespace dh::cap;

namespace {

std::string refusal(const std::string& yaml, const std::set<std::string>& names = {}) {
  const ConfigNode root = ConfigNode::load_string(yaml, "test.yaml");
  Theta theta;
  const ConfigNode params = root.child("parameters");
  for (const auto& k : params.keys()) theta[k] = params.get<double>(k);
  try {
    load_theta_ranges(root, theta);
    refuse_keyed_parameters(root, theta, names);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

const std::string kRange = "{unit: m, min: 0.01, max: 0.2, what: \"height above the grasp\"}";

}  // namespace

TEST(ThetaRanges, TheShippedLibraryDeclaresEveryParameterAndStaysInside) {
  const LibraryTheta lib = load_library_theta(paths::config_dir() / "library");
  for (const auto& [capability, theta] : lib.theta) {
    ASSERT_TRUE(lib.ranges.count(capability)) << capability;
    const ThetaRanges& ranges = lib.ranges.at(capability);
    EXPECT_EQ(ranges.size(), theta.size()) << capability;
    for (const auto& [name, value] : theta) {
      const ParameterRange& r = ranges.at(name);
      EXPECT_LE(r.min, value) << capability << "." << name;
      EXPECT_GE(r.max, value) << capability << "." << name;
      EXPECT_FALSE(r.what.empty()) << capability << "." << name;
    }
  }
}

TEST(ThetaRanges, AMissingOrViolatedOrMalformedRangeIsRefusedByName) {
  EXPECT_EQ(refusal("parameters: {approach_height: 0.08}\nranges: {approach_height: " + kRange + "}\n"), "");
  EXPECT_NE(refusal("parameters: {approach_height: 0.08}\n").find("ranges"), std::string::npos);
  EXPECT_NE(refusal("parameters: {approach_height: 0.08, lift: 0.1}\nranges: {approach_height: " + kRange + "}\n")
                .find("parameter 'lift' declares no range"),
            std::string::npos);
  const std::string outside = refusal("parameters: {approach_height: 0.5}\nranges: {approach_height: " + kRange + "}\n");
  EXPECT_NE(outside.find("'approach_height' = 0.5 m lies outside its physical range [0.01, 0.2]"), std::string::npos)
      << outside;
  EXPECT_NE(refusal("parameters: {a: 1}\nranges: {a: {unit: furlong, min: 0, max: 2, what: x}}\n").find("furlong"),
            std::string::npos);
  EXPECT_NE(refusal("parameters: {a: 1}\nranges: {a: {unit: m, min: 2, max: 2, what: x}}\n").find("not below max"),
            std::string::npos);
  EXPECT_NE(refusal("parameters: {n: 10}\nranges: {n: {unit: steps, min: 0.5, max: 20, what: x}}\n").find("whole numbers"),
            std::string::npos);
  EXPECT_NE(refusal("parameters: {a: 1}\nranges: {a: {unit: m, min: 0, max: 2, what: \"\"}}\n").find("empty"),
            std::string::npos);
  EXPECT_NE(refusal("parameters: {a: 1}\nranges: {a: {unit: m, min: 0, max: 2, what: x}, b: {unit: m, min: 0, max: 2, "
                    "what: x}}\n")
                .find("not one of the parameters"),
            std::string::npos);
}

TEST(ThetaRanges, AParameterKeyedToATaskSceneOrObjectIsRefused) {
  const std::set<std::string> names{"bowl", "moka_pot", "stove"};
  const auto with = [&](const std::string& name) {
    return refusal("parameters: {" + name + ": 0.1}\nranges: {" + name + ": " + kRange + "}\n", names);
  };
  EXPECT_EQ(with("approach_height"), "");
  EXPECT_EQ(with("bowlish_height"), "") << "a part of a word is not the object";
  EXPECT_NE(with("bowl_lift").find("keyed to 'bowl'"), std::string::npos);
  EXPECT_NE(with("lift_over_moka_pot").find("keyed to 'moka_pot'"), std::string::npos);
  EXPECT_NE(with("task3_speed").find("keyed to a task"), std::string::npos);
  EXPECT_NE(with("speed_seed").find("keyed to a seed"), std::string::npos);
}
