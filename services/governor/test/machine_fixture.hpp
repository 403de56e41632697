// The episode-machine fixture shared by the governor's unit tests.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "dh/common/evidence.hpp"
#include "dh/gov/episode.hpp"
#include "fixtures.hpp"

namespace dh::test {

/// An episode machine on "put the bowl on the plate" with pick_place announced; its evidence goes to a
/// file of the test's own. A derived fixture adjusts the configuration in configure().
struct MachineTest : ::testing::Test {
  std::filesystem::path file = std::filesystem::temp_directory_path() /
                               ("dh_machine_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
                                ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".jsonl");
  gov::Registry registry;
  gov::GovernorConfig config;
  std::unique_ptr<EvidenceWriter> evidence;
  std::unique_ptr<gov::EpisodeMachine> m;
  gov::Clock::time_point t0 = gov::Clock::time_point{} + std::chrono::seconds(1000);

  virtual void configure(gov::GovernorConfig&) {}
  virtual void configure_spec(gov::EpisodeSpec&) {}
  void SetUp() override {
    configure(config);
    gov::EpisodeSpec spec{0, "ep", "put the bowl on the plate", "full", 300};
    configure_spec(spec);
    std::filesystem::remove(file);
    registry.announce(pick_place_info());
    evidence = std::make_unique<EvidenceWriter>(file);
    m = std::make_unique<gov::EpisodeMachine>(spec, config, registry, *evidence, t0);
  }
  void TearDown() override { std::filesystem::remove(file); }
  gov::Advice good(const std::string& id) {
    return {id, false, "pick_place", {{"object", "bowl"}, {"target", "plate"}}, "", "", "rules", false, {}};
  }
  std::vector<std::string> kinds() {
    std::vector<std::string> k;
    for (const auto& r : read_evidence(file)) k.push_back(r["kind"]);
    return k;
  }
};

}  // namespace dh::test
