// dh_cap_vla_act: the vla_act capability as its own process (see dh/cap/host.hpp, dh/cap/vla_act.hpp).
//   --backend embedded       the frozen MLP of a weight file written by `dh train-policy` (default
//                            $DH_RUNS_DIR/policy/vla_mlp.dhp); a missing or corrupt file ends the process
//                            at start with the reason.
//   --backend policy-server  an openpi policy server (--server ws://host:8000), fed the channel's latest
//                            agentview and wrist images from rt/dh/camera (sim_worker --cameras agentview,wrist).
#include <CLI/CLI.hpp>

#include <optional>

#include "dh/cap/host.hpp"
#include "dh/cap/policy_server_source.hpp"
#include "dh/common/dds.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/cameraPubSubTypes.h"

int main(int argc, char** argv) {
  std::string backend = "embedded", weights, server = "ws://127.0.0.1:8000";
  // Below the governor's stalled-step deadline (10 s): one request blocks this process's event loop.
  unsigned timeout_ms = 5000, max_image_age = 10;
  auto options = [&](CLI::App& app) {
    app.add_option("--backend", backend, "where actions come from")->check(CLI::IsMember({"embedded", "policy-server"}));
    app.add_option("--weights", weights, "embedded: weight file (default $DH_RUNS_DIR/policy/vla_mlp.dhp)");
    app.add_option("--server", server, "policy-server: the openpi server's websocket URL");
    app.add_option("--server-timeout-ms", timeout_ms, "policy-server: bound on one request, connection included");
    app.add_option("--max-image-age", max_image_age, "policy-server: steps a camera image may lag the observation");
  };
  // The camera subscription lives as long as the host runs the capability.
  std::optional<dh::dds::Participant> cameras;
  std::optional<dh::dds::Reader<dh::msg::CameraImagePubSubType>> camera_reader;
  auto make = [&] {
    std::shared_ptr<dh::cap::ActionSource> source;
    if (backend == "embedded") {
      const auto file = weights.empty() ? dh::paths::runs_dir() / "policy" / "vla_mlp.dhp" : std::filesystem::path(weights);
      source = std::make_shared<dh::cap::EmbeddedPolicy>(dh::policy::load_policy(file));
    } else {
      auto images = std::make_shared<dh::cap::ImageCache>();
      cameras.emplace("dh_cap_vla_act_cameras");
      camera_reader.emplace(*cameras, dh::topics::kCamera, dh::dds::Qos::Camera,
                            dh::dds::Reader<dh::msg::CameraImagePubSubType>::Callbacks{
                                [images](const dh::msg::CameraImage& m, const auto&) {
                                  if (m.encoding() != "rgb8" || m.width() == 0 || m.height() == 0 ||
                                      m.data().size() != 3ull * m.width() * m.height())
                                    return;
                                  images->put(m.channel(), m.episode_id(), m.camera(), m.step(),
                                              {m.camera(), static_cast<int>(m.width()), static_cast<int>(m.height()),
                                               {m.data().begin(), m.data().end()}});
                                },
                                {},
                                {}});
      source = std::make_shared<dh::cap::PolicyServerSource>(server, std::chrono::milliseconds(timeout_ms), images,
                                                             max_image_age);
    }
    return std::vector<dh::cap::CapabilityDef>{dh::cap::vla_act_def(source)};
  };
  return dh::cap::run_capability_host(argc, argv, "vla_act", options, make);
}
