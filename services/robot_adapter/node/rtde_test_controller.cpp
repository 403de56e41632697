// rtde_test_controller: the RTDE test controller as a process, a test double for the metal, not a robot.
// It serves RTDE and a script port on 127.0.0.1, backed by the UR7e in MuJoCo (simulated_ur.hpp), for the
// cell's dry run and for trying the adapter by hand. Every second it logs the arm's peak joint speed, so a
// stop can be seen. Parameters: --port (RTDE), --script-port, --urdf, --ready-q (6 joint values, rad).
#include <CLI/CLI.hpp>
#include <thread>

#include "dh/common/log.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/shutdown.hpp"
#include "dh/rtde/simulated_ur.hpp"

int main(int argc, char** argv) {
  CLI::App app(
      "the RTDE test controller: a UR7e in MuJoCo behind RTDE on loopback (a test double, not a robot)");
  std::uint16_t port = 30004, script_port = 30002;
  std::string urdf = (dh::paths::config_dir() / "robots" / "ur7e.urdf").string();
  std::vector<double> ready{0, -1.3, 1.6, -1.87, -1.5708, 0};
  app.add_option("--port", port, "RTDE port on 127.0.0.1");
  app.add_option("--script-port", script_port, "the secondary interface's stand-in on 127.0.0.1");
  app.add_option("--urdf", urdf, "the arm (6 joints)")->check(CLI::ExistingFile);
  app.add_option("--ready-q", ready, "the arm's joints at start (rad)")->delimiter(',')->expected(6);
  CLI11_PARSE(app, argc, argv);
  auto log = dh::make_logger("rtde_test_controller");
  dh::install_shutdown_handlers();
  try {
    dh::rtde::SimulatedController controller(
        urdf, {ready[0], ready[1], ready[2], ready[3], ready[4], ready[5]}, port, script_port);
    log->info("serving RTDE on 127.0.0.1:{} and scripts on 127.0.0.1:{} (a test double, not a robot)",
              controller.port(), controller.script_port());
    while (!dh::shutdown_requested()) {
      std::this_thread::sleep_for(std::chrono::seconds(1));
      const auto [running, peak] = controller.with_arm([](dh::rtde::SimulatedUr& a) {
        const std::pair<bool, double> r{a.program_running(), a.peak_speed()};
        a.reset_peak();
        return r;
      });
      log->debug("program {} peak joint speed {:.4f} rad/s", running ? "running" : "stopped", peak);
    }
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return 1;
  }
  return 0;
}
