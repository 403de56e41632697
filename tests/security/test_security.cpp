// The secured deployment (deploy/secure.yaml, keys and documents by deploy/security/make_keys) over real
// processes: an episode runs under it; participants without a valid certificate (one from another CA, one
// with no security at all) read nothing and write nothing that arrives; a capability whose permissions
// lack rt/dh/action cannot move the robot. Every participant other than the services and `dh` is a
// sec_probe process (one identity per process: Fast DDS loads one `dh_participant` profile per process).
#include <algorithm>
#include <fstream>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "dh/common/evidence.hpp"
#include "dh/common/topics.hpp"
#include "harness.hpp"

namespace dh {
using namespace std::chrono_literals;
using nlohmann::json;

namespace {

namespace fs = std::filesystem;

const std::vector<std::string> kAllTopics = {
    topics::kAnnounce, topics::kCommand, topics::kCommandStatus, topics::kLease, topics::kAction,
    topics::kObservation, topics::kVerdict, topics::kSeamEvent, topics::kPlanRequest, topics::kAdvice,
    topics::kEpisodeRequest, topics::kEpisodeResult, topics::kChannelStatus, topics::kCamera,
    topics::kSceneEstimate, topics::kRgbd, topics::kRgbdRequest};

std::string join(const std::vector<std::string>& v) {
  std::string out;
  for (const auto& s : v) out += (out.empty() ? "" : " ") + s;
  return out;
}

std::string slurp(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// make_keys DIR with the project's grants plus `extra` (test-only participants).
void make_keys(const fs::path& dir, const std::string& extra) {
  const fs::path extra_file = dir.string() + "-extra-grants.txt";
  std::ofstream(extra_file) << extra;
  const auto script = paths::home() / "deploy" / "security" / "make_keys";
  const auto [out, status] = itest::run_command(script.string() + " " + dir.string() + " --grants " +
                                                (paths::home() / "deploy" / "security" / "grants.txt").string() +
                                                " --grants " + extra_file.string() + " 2>&1");
  ASSERT_EQ(status, 0) << out;
}

/// The services of deploy/secure.yaml named in `names` (all of them when empty), each with its profile.
std::vector<cli::ServiceSpec> secure_services(const std::set<std::string>& names = {}) {
  std::vector<cli::ServiceSpec> out;
  for (auto& s : cli::load_launch_file(paths::home() / "deploy" / "secure.yaml"))
    if (names.empty() || names.count(s.name)) out.push_back(s);
  return out;
}

/// A sec_probe process named `name` with the identity of `profile`; it reports to probes/<name>.json.
cli::ServiceSpec probe(const fs::path& runs, const std::string& name, const fs::path& profile,
                       std::vector<std::string> args) {
  fs::create_directories(runs / "probes");
  args.insert(args.begin(), {"--status", (runs / "probes" / (name + ".json")).string()});
  return {name, "sec_probe", std::move(args), "", false, {{"DH_DDS_PROFILE", profile.string()}}};
}

json status(const fs::path& runs, const std::string& name) {
  std::ifstream in(runs / "probes" / (name + ".json"));
  if (!in) return json::object();
  auto j = json::parse(in, nullptr, false);
  return j.is_discarded() ? json::object() : j;
}

/// Polls `pred` every 100 ms until it holds or `timeout` passes; returns pred().
template <class Pred>
bool eventually(std::chrono::milliseconds timeout, Pred pred) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() >= end) return pred();
    std::this_thread::sleep_for(100ms);
  }
  return true;
}

int samples(const json& s, const std::string& topic) {
  return s.contains("samples") && s["samples"].is_object() ? s["samples"].value(topic, 0) : 0;
}

bool contains(const json& array, const std::string& value) {
  return array.is_array() && std::find(array.begin(), array.end(), value) != array.end();
}

/// Capability instances the governor holds alive, from its log ("announced", "liveliness asserted" and
/// "liveliness lost" lines), and how many losses it has logged.
std::pair<int, int> governor_view(const fs::path& runs) {
  std::istringstream log(slurp(runs / "logs" / "governor.log"));
  std::map<std::string, bool> alive;
  int losses = 0;
  for (std::string line; std::getline(log, line);) {
    const auto at = line.find("instance=");
    if (at == std::string::npos) continue;
    const std::string instance = line.substr(at + 9, line.find(' ', at) - at - 9);
    if (line.find("liveliness lost") != std::string::npos) {
      alive[instance] = false;
      ++losses;
    } else if (line.find("announced (cost") != std::string::npos || line.find("liveliness asserted") != std::string::npos) {
      alive[instance] = true;
    }
  }
  return {static_cast<int>(std::count_if(alive.begin(), alive.end(), [](const auto& a) { return a.second; })), losses};
}

/// Waits (up to `timeout`) until the governor holds `n` capability instances alive and has logged no
/// liveliness loss for 3 s: with 1 s liveliness leases, a process starved of CPU for a second (2 loaded
/// cores, a dozen processes starting) is taken for lost, and an episode started then is planned without
/// its capabilities.
bool governor_settled(const fs::path& runs, int n, std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  auto quiet_since = std::chrono::steady_clock::now();
  int last_losses = -1;
  while (std::chrono::steady_clock::now() < end) {
    const auto [alive, losses] = governor_view(runs);
    if (losses != last_losses || alive < n) quiet_since = std::chrono::steady_clock::now();
    last_losses = losses;
    if (alive >= n && std::chrono::steady_clock::now() - quiet_since >= 3s) return true;
    std::this_thread::sleep_for(100ms);
  }
  return false;
}

}  // namespace

// deploy/secure.yaml as it is: every service with its own certificate and permissions, `dh run` with the
// command line's identity (dh.xml).
TEST(Security, AnEpisodeRunsUnderTheSecuredProfile) {
  itest::IsolatedEnv env;
  ASSERT_NO_FATAL_FAILURE(make_keys(env.runs / "security", ""));
  const auto t0 = std::chrono::steady_clock::now();
  cli::Deployment d(secure_services(), paths::bin_dir(), env.runs / "logs");
  // Nine capability instances: pick_place, push, slide_drawer, turn_knob, swing_door and cap_recovery's four
  // (cap_vla_act ends at start without trained weights).
  ASSERT_TRUE(eventually(60s, [&] { return governor_view(env.runs).first >= 9; }))
      << "the governor did not authenticate every capability process:\n" << slurp(env.runs / "logs" / "governor.log");
  const double heard_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(governor_settled(env.runs, 9, 60s)) << slurp(env.runs / "logs" / "governor.log");
  const std::string profile = (env.runs / "security" / "dh.xml").string();
  // No fallback: should nothing answer, `dh run` fails on the missing launch file instead of starting an
  // unsecured deployment.
  const auto [out, status] = itest::run_command(
      "DH_DDS_PROFILE=" + profile + " " + (paths::bin_dir() / "dh").string() +
      " run --suite goal --task 8 --seed 1 --json --ready-timeout-ms 60000 --timeout 120 --launch " +
      (env.runs / "no-fallback.yaml").string());
  ASSERT_EQ(status, 0) << out;
  const auto j = json::parse(out);
  EXPECT_TRUE(j["success"].get<bool>()) << out << "\n" << slurp(env.runs / "logs" / "governor.log");
  EXPECT_GT(j["steps"].get<int>(), 100);
  EXPECT_LE(j["steps"].get<int>(), 300);
  std::map<std::string, int> kinds;
  for (const auto& r : read_evidence(j["evidence"].get<std::string>())) ++kinds[r["kind"]];
  for (const char* k : {"episode_start", "plan_request", "advice", "dispatch", "command_status", "decision",
                        "verdict_event", "episode_end"})
    EXPECT_GT(kinds[k], 0) << "evidence has no '" << k << "' record";
  std::printf("secured: the governor heard all 9 capabilities %.2f s after launch; episode wall %.3f s, %d steps\n",
              heard_s, j["wall_s"].get<double>(), j["steps"].get<int>());
  // Each service created every reader and writer it needs: a grant missing from grants.txt ends the service
  // at start ("cannot create a writer/reader on ..."). cap_vla_act ends for want of weights only.
  for (const auto& name : d.exited()) {
    EXPECT_EQ(name, "cap_vla_act") << "service '" << name << "' exited: " << slurp(env.runs / "logs" / (name + ".log"));
    EXPECT_EQ(slurp(env.runs / "logs" / (name + ".log")).find("cannot create"), std::string::npos);
  }
}

// Two participants without a valid certificate listen to every topic and ask for an episode and send actions
// while a legitimate episode runs: one has a certificate, permissions and governance made by another CA (its
// own documents allow it everything), one has no security at all (deploy/dds/loopback.xml).
TEST(Security, AParticipantWithoutAValidCertificateReadsNothingAndWritesNothing) {
  itest::IsolatedEnv env;
  ASSERT_NO_FATAL_FAILURE(make_keys(env.runs / "security",
                                    "watch pub rt/dh/episode/request\n"
                                    "watch sub rt/dh/observation rt/dh/sim/channel rt/dh/episode/result "
                                    "rt/dh/seam/event\n"));
  ASSERT_NO_FATAL_FAILURE(make_keys(env.runs / "other-ca", "intruder pub " + join(kAllTopics) + "\nintruder sub " +
                                                               join(kAllTopics) + "\n"));
  cli::Deployment core(secure_services({"sim_worker", "governor", "planner", "cap_pick_place", "cap_recovery"}),
                       paths::bin_dir(), env.runs / "logs");
  ASSERT_TRUE(governor_settled(env.runs, 5, 60s)) << slurp(env.runs / "logs" / "governor.log");

  const std::vector<std::string> reads = {"--read", "rt/dh/observation", "--read", "rt/dh/sim/channel",
                                          "--read", "rt/dh/episode/result", "--read", "rt/dh/capability/announce",
                                          "--read", "rt/dh/verdict", "--read", "rt/dh/seam/event",
                                          "--read", "rt/dh/command"};
  auto outsider = [&](const std::string& name, const fs::path& profile) {
    auto args = reads;
    // Channel 1 is idle: a request that arrived would start an episode there; an action that arrived would
    // be rejected by the seam and recorded on rt/dh/seam/event with its command id.
    args.insert(args.end(), {"--request", name + "-episode", "--channel", "1", "--act", name + "-cmd", "--episode",
                             name + "-episode"});
    return probe(env.runs, name, profile, args);
  };
  cli::Deployment probes({outsider("intruder", env.runs / "other-ca" / "intruder.xml"),
                          outsider("plain", paths::home() / "deploy" / "dds" / "loopback.xml"),
                          probe(env.runs, "watch", env.runs / "security" / "watch.xml",
                                {"--read", "rt/dh/observation", "--read", "rt/dh/sim/channel", "--read",
                                 "rt/dh/episode/result", "--read", "rt/dh/seam/event"})},
                         paths::bin_dir(), env.runs / "logs");
  const auto probes_up = std::chrono::steady_clock::now();
  // The legitimate side is connected (it hears the simulator's channel announcements), and the outsiders
  // are up with every reader and writer created (their own documents allow them everything).
  ASSERT_TRUE(eventually(60s, [&] { return samples(status(env.runs, "watch"), "rt/dh/sim/channel") > 0; }))
      << status(env.runs, "watch").dump();
  for (const char* name : {"intruder", "plain"})
    ASSERT_TRUE(eventually(30s, [&] { return status(env.runs, name).value("participant", "") == "ok"; }))
        << name << ": " << status(env.runs, name).dump() << slurp(env.runs / "logs" / (std::string(name) + ".log"));

  // A legitimate episode while they listen.
  const auto [out, rc] = itest::run_command(
      "DH_DDS_PROFILE=" + (env.runs / "security" / "dh.xml").string() + " " + (paths::bin_dir() / "dh").string() +
      " run --suite goal --task 8 --seed 1 --json --ready-timeout-ms 60000 --timeout 120 --launch " +
      (env.runs / "no-fallback.yaml").string());
  ASSERT_EQ(rc, 0) << out;
  const auto episode = json::parse(out);
  ASSERT_TRUE(episode["success"].get<bool>()) << out << "\n" << slurp(env.runs / "logs" / "governor.log");
  // Give the outsiders at least 15 s in all (legitimate participants find each other in about 2 s).
  std::this_thread::sleep_until(probes_up + 15s);
  probes.stop();

  const json watch = status(env.runs, "watch");
  EXPECT_GE(samples(watch, "rt/dh/observation"), 100) << "the legitimate side saw the episode: " << watch.dump();
  EXPECT_GE(watch["participants"].value("authorized", 0), 5) << watch.dump();
  EXPECT_TRUE(contains(watch["episodes"], episode["episode_id"].get<std::string>())) << watch.dump();
  for (const char* name : {"intruder", "plain"}) {
    SCOPED_TRACE(name);
    const json s = status(env.runs, name);
    ASSERT_TRUE(s.value("done", false)) << s.dump();
    EXPECT_EQ(s["participant"], "ok");
    // It was there: the deployment's participants announced themselves to it (participant discovery is not
    // secret), but not one of them authenticated it.
    if (std::string(name) == "intruder") {
      EXPECT_GE(s["participants"].value("unauthorized", 0), 1) << "no authentication was refused: " << s.dump();
      EXPECT_EQ(s["participants"].value("authorized", -1), 0) << s.dump();
    } else {
      EXPECT_GE(s["participants"].value("discovered", 0), 1) << "it never saw the deployment: " << s.dump();
    }
    for (const auto& [topic, state] : s["readers"].items()) EXPECT_EQ(state, "ok") << topic;
    for (const auto& [topic, n] : s["samples"].items()) EXPECT_EQ(n, 0) << "read " << n << " samples of " << topic;
    EXPECT_TRUE(s["episodes"].empty()) << s.dump();
    EXPECT_EQ(s["writers"].value("rt/dh/episode/request", ""), "ok");
    EXPECT_EQ(s["writers"].value("rt/dh/action", ""), "ok");
    EXPECT_GE(s.value("actions_written", 0), 20);
    EXPECT_EQ(s["matched"].value("rt/dh/episode/request", -1), 0) << "a legitimate reader matched its request writer";
    EXPECT_EQ(s["matched"].value("rt/dh/action", -1), 0) << "a legitimate reader matched its action writer";
    // Nothing it wrote arrived: its episode never started, and the seam never saw its actions.
    const std::string ep = std::string(name) + "-episode", cmd = std::string(name) + "-cmd";
    EXPECT_FALSE(contains(watch["episodes"], ep)) << watch.dump();
    EXPECT_FALSE(contains(watch["seam_commands"], cmd)) << watch.dump();
    for (const char* log : {"sim_worker.log", "governor.log"})
      EXPECT_EQ(slurp(env.runs / "logs" / log).find(ep), std::string::npos) << log;
  }
}

// A capability-like participant `cap_rogue`, certified by the deployment's CA, whose permissions are a
// capability's minus rt/dh/action.
TEST(Security, ACapabilityWithoutTheActionGrantCannotMoveTheRobot) {
  itest::IsolatedEnv env;
  const fs::path keys = env.runs / "security";
  ASSERT_NO_FATAL_FAILURE(make_keys(keys,
                                    "watch pub rt/dh/episode/request\n"
                                    "watch sub rt/dh/observation rt/dh/seam/event\n"
                                    "cap_rogue pub rt/dh/command/status rt/dh/capability/announce\n"
                                    "cap_rogue sub rt/dh/command rt/dh/observation\n"));
  // The same identity with access control switched off on its own side (no Access-Permissions plugin):
  // nothing stops it locally from creating the action writer.
  {
    std::istringstream in(slurp(keys / "cap_rogue.xml"));
    std::ofstream out(keys / "cap_rogue_noacl.xml");
    int dropped = 0;
    for (std::string line; std::getline(in, line);)
      if (line.find("dds.sec.access.") == std::string::npos) out << line << "\n";
      else ++dropped;
    ASSERT_EQ(dropped, 4);
  }
  cli::ServiceSpec sim{"sim_worker", "sim_worker", {"--channels", "1", "--lease-grace-ms", "300"}, "", false,
                       {{"DH_DDS_PROFILE", (keys / "sim_worker.xml").string()}}};
  cli::Deployment core({sim}, paths::bin_dir(), env.runs / "logs");

  // 1. The real capability process under cap_rogue's identity ends at start: Fast DDS refuses the writer.
  cli::Deployment rogue({{"cap_rogue", "cap_pick_place", {}, "", false,
                          {{"DH_DDS_PROFILE", (keys / "cap_rogue.xml").string()}}}},
                        paths::bin_dir(), env.runs / "logs");
  ASSERT_TRUE(eventually(30s, [&] { return !rogue.exited().empty(); })) << "cap_pick_place as cap_rogue kept running";
  const std::string rogue_log = slurp(env.runs / "logs" / "cap_rogue.log");
  EXPECT_NE(rogue_log.find("cannot create a writer on rt/dh/action"), std::string::npos) << rogue_log;
  EXPECT_NE(rogue_log.find("rt/dh/action topic not found in allow rule"), std::string::npos) << rogue_log;
  EXPECT_EQ(rogue_log.find("announced"), std::string::npos) << rogue_log;

  // 2. An episode on the channel (started by `watch`, which also reads the observation and the seam's events).
  cli::Deployment watch({probe(env.runs, "watch", keys / "watch.xml",
                               {"--read", "rt/dh/observation", "--read", "rt/dh/seam/event", "--request",
                                "rogue-target", "--channel", "0"})},
                        paths::bin_dir(), env.runs / "logs");
  ASSERT_TRUE(eventually(60s, [&] { return status(env.runs, "watch")["steps"].contains("rogue-target"); }))
      << status(env.runs, "watch").dump();

  // 3. Three action writers for that episode: cap_rogue with access control (refused locally), cap_rogue
  // without it (created, never matched), and a real capability's identity (cap_push) as the control: its
  // actions reach the seam, which rejects them (no lease) and says so on rt/dh/seam/event.
  auto act = [&](const std::string& name, const fs::path& profile, std::vector<std::string> extra) {
    std::vector<std::string> args = {"--read", "rt/dh/observation", "--act", name, "--episode", "rogue-target",
                                     "--channel", "0"};
    args.insert(args.end(), extra.begin(), extra.end());
    return probe(env.runs, name, profile, args);
  };
  cli::Deployment probes({act("rogue-acl", keys / "cap_rogue.xml",
                              {"--read", "rt/dh/command", "--write", "rt/dh/command/status", "--write",
                               "rt/dh/capability/announce"}),
                          act("rogue-noacl", keys / "cap_rogue_noacl.xml", {}), act("control", keys / "cap_push.xml", {})},
                         paths::bin_dir(), env.runs / "logs");
  ASSERT_TRUE(eventually(60s, [&] { return contains(status(env.runs, "watch")["seam_commands"], "control"); }))
      << "the control's actions never reached the seam: " << status(env.runs, "watch").dump();
  ASSERT_TRUE(eventually(60s, [&] { return samples(status(env.runs, "rogue-acl"), "rt/dh/observation") > 0; }))
      << status(env.runs, "rogue-acl").dump();
  std::this_thread::sleep_for(5s);  // more time for the rogue's actions than the control needed
  probes.stop();
  watch.stop();

  const json acl = status(env.runs, "rogue-acl"), noacl = status(env.runs, "rogue-noacl"),
             control = status(env.runs, "control"), w = status(env.runs, "watch");
  // With access control on its side, the participant is authenticated and may do what its grant says (read
  // the observation, write status and announcements), but the action writer is refused, with the reason.
  EXPECT_EQ(acl["participant"], "ok");
  EXPECT_EQ(acl["readers"].value("rt/dh/observation", ""), "ok");
  EXPECT_GT(samples(acl, "rt/dh/observation"), 0);
  EXPECT_EQ(acl["writers"].value("rt/dh/command/status", ""), "ok");
  EXPECT_EQ(acl["writers"].value("rt/dh/capability/announce", ""), "ok");
  EXPECT_EQ(acl["writers"].value("rt/dh/action", ""), "refused: cannot create a writer on rt/dh/action") << acl.dump();
  EXPECT_NE(acl["fastdds_errors"].dump().find("rt/dh/action topic not found in allow rule"), std::string::npos)
      << acl.dump();
  EXPECT_EQ(acl.value("actions_written", 0), 0);
  // Without it, the writer exists and writes, but the simulator worker (which checks the remote permissions
  // it received at authentication) never matches it: nothing arrives, nothing is read.
  EXPECT_EQ(noacl["participant"], "ok") << noacl.dump();
  EXPECT_EQ(noacl["writers"].value("rt/dh/action", ""), "ok") << noacl.dump();
  EXPECT_GE(noacl.value("actions_written", 0), 20);
  EXPECT_EQ(noacl["participants"].value("authorized", -1), 0) << "no participant completed authentication with it";
  EXPECT_EQ(noacl["matched"].value("rt/dh/action", -1), 0) << noacl.dump();
  EXPECT_EQ(samples(noacl, "rt/dh/observation"), 0) << noacl.dump();
  // The control was matched and heard; the rogues never were; the robot never moved (no lease: the seam
  // rejects even the control's actions).
  EXPECT_GE(control["matched"].value("rt/dh/action", 0), 1) << control.dump();
  EXPECT_TRUE(contains(w["seam_commands"], "control"));
  EXPECT_FALSE(contains(w["seam_commands"], "rogue-noacl")) << w.dump();
  EXPECT_FALSE(contains(w["seam_commands"], "rogue-acl")) << w.dump();
  EXPECT_EQ(w["steps"].value("rogue-target", -1), 0) << w.dump();
}

}  // namespace dh
