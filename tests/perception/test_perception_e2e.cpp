// The perception service over DDS: it asks sim_worker for workcell frames, publishes scene estimates
// close to the simulator's truth, and an episode of the full-perception arm grounds from them; with a parts
// camera its estimates carry the fixtures' parts.
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "../integration/harness.hpp"
#include "dh/common/dds.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/episodePubSubTypes.h"
#include "dh/msg/perceptionPubSubTypes.h"
#include "dh/msg/robotPubSubTypes.h"

namespace dh {
using namespace std::chrono_literals;

TEST(PerceptionE2E, EstimatesFollowTheSimulatorAndTheFullPerceptionArmGroundsFromThem) {
  itest::IsolatedEnv env;
  cli::Deployment d({itest::service("sim_worker"), itest::service("governor"), itest::service("planner", {"--backend", "rules"}),
                     itest::service("cap_pick_place"), itest::service("perception")},
                    paths::bin_dir(), env.runs / "logs");
  dds::Participant p("itest");
  std::mutex m;
  std::condition_variable cv;
  std::optional<msg::Observation> first;
  std::vector<msg::SceneEstimate> estimates;
  dds::Reader<msg::ObservationPubSubType> obs(p, topics::kObservation, dds::Qos::Observation,
      {[&](const msg::Observation& o, const auto&) { std::lock_guard l(m); if (o.step() == 0 && !first) first = o; cv.notify_all(); }, {}, {}});
  dds::Reader<msg::SceneEstimatePubSubType> scene(p, topics::kSceneEstimate, dds::Qos::Observation,
      {[&](const msg::SceneEstimate& e, const auto&) { std::lock_guard l(m); estimates.push_back(e); cv.notify_all(); }, {}, {}});
  const std::string dh = (paths::bin_dir() / "dh").string();
  auto [out, status] = itest::run_command(dh + " run --suite goal --task 8 --seed 4 --arm full-perception --json --ready-timeout-ms 20000");
  ASSERT_EQ(status, 0) << out;
  const auto j = nlohmann::json::parse(out);
  EXPECT_TRUE(j["success"].get<bool>()) << j.dump();

  std::lock_guard l(m);
  ASSERT_TRUE(first.has_value());
  ASSERT_FALSE(estimates.empty()) << "the perception service published nothing";
  const msg::SceneEstimate& e0 = estimates.front();
  EXPECT_EQ(e0.step(), 0u);
  const auto looked = e0.looked_for();
  EXPECT_NE(std::find(looked.begin(), looked.end(), "bowl"), looked.end());
  for (const char* name : {"bowl", "plate"}) {
    const auto seen = std::find_if(e0.seen().begin(), e0.seen().end(), [&](const auto& s) { return s.entity() == name; });
    ASSERT_NE(seen, e0.seen().end()) << name << " not seen";
    const auto truth = std::find_if(first->entities().begin(), first->entities().end(),
                                    [&](const auto& t) { return t.name() == name; });
    ASSERT_NE(truth, first->entities().end());
    const double dx = seen->centroid()[0] - truth->pose().p()[0], dy = seen->centroid()[1] - truth->pose().p()[1];
    EXPECT_LT(std::hypot(dx, dy), 0.01) << name << " more than 1 cm off the simulator's truth";
  }
  // The governor waited for the frame of step 0, then grounded from it.
  std::ifstream in(j["evidence"].get<std::string>());
  bool waited = false, grounded = false;
  for (std::string line; std::getline(in, line);) {
    const auto r = nlohmann::json::parse(line);
    waited |= r["kind"] == "awaiting_perception";
    grounded |= r["kind"] == "grounding";
  }
  EXPECT_TRUE(grounded);
  std::printf("perception: %zu estimates, first after the governor %s for it\n", estimates.size(),
              waited ? "waited" : "did not wait");
}

// The verdict from perception: the episode ends on the goal judged on perceived frames, the simulator's
// verdict is recorded beside it, and an arm that does not ground from perception cannot use it.
TEST(PerceptionE2E, TheVerdictFromPerceptionEndsTheEpisodeAndTheOraclesIsRecordedBesideIt) {
  itest::IsolatedEnv env;
  cli::Deployment d({itest::service("sim_worker"), itest::service("governor"), itest::service("planner", {"--backend", "rules"}),
                     itest::service("cap_pick_place"), itest::service("perception")},
                    paths::bin_dir(), env.runs / "logs");
  const std::string dh = (paths::bin_dir() / "dh").string();
  auto [out, status] = itest::run_command(
      dh + " run --suite goal --task 1 --seed 4 --arm full-perception --verifier perception --json --ready-timeout-ms 20000");
  ASSERT_EQ(status, 0) << out;
  const auto j = nlohmann::json::parse(out);
  EXPECT_TRUE(j["success"].get<bool>()) << j.dump();
  std::ifstream in(j["evidence"].get<std::string>());
  std::string verifier;
  std::optional<std::uint32_t> perceived_at, oracle_at;
  for (std::string line; std::getline(in, line);) {
    const auto r = nlohmann::json::parse(line);
    if (r["kind"] == "episode_start") verifier = r.value("verifier", "");
    if (r["kind"] == "perceived_verdict" && r["value"] == true && !perceived_at) perceived_at = r["step"].get<std::uint32_t>();
    if (r["kind"] == "verdict_event" && r["value"] == true && !oracle_at) oracle_at = r["step"].get<std::uint32_t>();
  }
  EXPECT_EQ(verifier, "perception");
  ASSERT_TRUE(perceived_at) << "no perceived verdict latched";
  ASSERT_TRUE(oracle_at) << "the simulator's verdict was not recorded";
  // Three frames, one every 10 steps, must agree: the perceived verdict comes after the simulator's.
  EXPECT_GE(*perceived_at, *oracle_at);
  EXPECT_GE(j["steps"].get<std::uint32_t>(), *perceived_at);

  auto [refused, refused_status] = itest::run_command(
      dh + " run --suite goal --task 8 --seed 4 --arm full --verifier perception --json --ready-timeout-ms 20000");
  ASSERT_EQ(refused_status, 0) << refused;
  const auto r = nlohmann::json::parse(refused);
  EXPECT_FALSE(r["success"].get<bool>());
  EXPECT_EQ(r["outcome"], "rejected") << r.dump();
  EXPECT_NE(r["reason"].get<std::string>().find("verifier perception needs an arm that grounds from perception"),
            std::string::npos) << r.dump();
}

// Parts from sensing: with a parts camera the service fits the drawer's travel to the front camera's depth,
// the fits follow the simulator's joint through the episode, and the perceived verdict that ends it reads
// the ring inside the drawer's region where the fitted travel put it.
TEST(PerceptionE2E, TheDrawersTravelFittedToTheFrontCameraFollowsTheSimulator) {
  itest::IsolatedEnv env;
  cli::Deployment d({itest::service("sim_worker"), itest::service("governor"), itest::service("planner", {"--backend", "rules"}),
                     itest::service("cap_pick_place"), itest::service("cap_slide_drawer"),
                     itest::service("perception", {"--parts-camera", "front"})},
                    paths::bin_dir(), env.runs / "logs");
  dds::Participant p("itest");
  std::mutex m;
  std::map<std::uint32_t, double> joint_at;  // the simulator's drawer travel by step
  std::vector<std::pair<std::uint32_t, msg::PerceivedPart>> fits;
  constexpr const char* kDrawer = "drawer_unit_drawer";
  dds::Reader<msg::ObservationPubSubType> obs(p, topics::kObservation, dds::Qos::Observation,
      {[&](const msg::Observation& o, const auto&) {
         for (const auto& e : o.entities())
           if (e.name() == kDrawer) {
             std::lock_guard l(m);
             joint_at[o.step()] = e.joint();
           }
       }, {}, {}});
  dds::Reader<msg::SceneEstimatePubSubType> scene(p, topics::kSceneEstimate, dds::Qos::Observation,
      {[&](const msg::SceneEstimate& e, const auto&) {
         std::lock_guard l(m);
         for (const auto& part : e.parts()) fits.emplace_back(e.step(), part);
       }, {}, {}});
  const std::string dh = (paths::bin_dir() / "dh").string();
  auto [out, status] = itest::run_command(
      dh + " run --suite hw --task 3 --seed 4 --arm full-perception --verifier perception --json --ready-timeout-ms 20000");
  ASSERT_EQ(status, 0) << out;
  const auto j = nlohmann::json::parse(out);
  EXPECT_TRUE(j["success"].get<bool>()) << j.dump();

  std::lock_guard l(m);
  ASSERT_FALSE(fits.empty()) << "no part in any estimate";
  std::size_t compared = 0, open = 0;
  for (const auto& [step, part] : fits) {
    ASSERT_EQ(part.entity(), kDrawer);
    const auto truth = joint_at.find(step);
    if (part.confidence() < 0.3 || truth == joint_at.end()) continue;
    ++compared;
    open += part.joint() > 0.14;
    // A frame is of the step it is stamped with or a little later (rendered after the step's observation).
    EXPECT_NEAR(part.joint(), truth->second, 0.01) << "step " << step;
    ASSERT_EQ(part.riders().size(), 2u) << "the drawer's handle and its inside ride on it";
  }
  EXPECT_GT(compared, fits.size() / 2) << "most frames fit the drawer with confidence";
  EXPECT_GT(open, 0u) << "no frame saw the drawer open";
}

}  // namespace dh
