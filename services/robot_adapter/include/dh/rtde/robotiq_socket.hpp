// A Robotiq gripper through its URCap's socket interface, and that interface's test double. The URCap on a
// UR controller serves ASCII lines on TCP 63352 (docs/ur-rtde.md, "The gripper"):
//
//   "SET <VAR> <n> [<VAR> <n> ...]\n"  ->  "ack\n"
//   "GET <VAR>\n"                      ->  "<VAR> <n>\n"
//
// Variables used here: ACT (1 activates), GTO (1: go to the requested position), POS (set: the requested
// position, 0 open to 255 closed; get: the fingers' measured position), SPE and FOR (speed and force,
// 0..255), STA (0 reset, 1 activating, 3 active), OBJ (0 moving, 1 stopped by an object while
// opening, 2 stopped by an object while closing, 3 at the requested position) and FLT (the fault code, 0
// none; robotiq_fault_text). After activation the fingers' measured position runs from about 3 (open) to
// about 230 (touching), not 0 to 255.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace dh::rtde {

/// The gripper cannot be reached or answered what it should not; what() names the exchange and why.
struct GripperError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// What GET OBJ answers.
enum class GripperObject : int { Moving = 0, StoppedOpening = 1, StoppedClosing = 2, AtRequest = 3 };

/// What a fault code of FLT means: "no fault" for 0, "unknown fault code" for one not listed. The codes and
/// their classes (priority, minor, major: a major one needs the gripper reset) as SDU Robotics' ur_rtde
/// lists them (`include/ur_rtde/robotiq_gripper.h`, eFaultCode; docs/ur-rtde.md).
std::string robotiq_fault_text(int code);

/// The measured positions of an activated 2F gripper's open and touching fingers (its encoder's range).
struct RobotiqRange {
  int open = 3, closed = 230;
};

/// The jaw's gap (m) a measured position means, for a jaw of `stroke_m` when fully open; clamped to the
/// stroke.
double robotiq_gap(int position, const RobotiqRange& range, double stroke_m);

class RobotiqClient {
 public:
  RobotiqClient();
  ~RobotiqClient();
  RobotiqClient(const RobotiqClient&) = delete;
  RobotiqClient& operator=(const RobotiqClient&) = delete;

  /// Connects to the URCap's server at `host`:`port`.
  void connect(const std::string& host, std::uint16_t port, std::chrono::milliseconds timeout);
  /// Sets variables in one line; GripperError unless the answer is "ack".
  void set(const std::vector<std::pair<std::string, int>>& values, std::chrono::milliseconds timeout);
  /// A variable's value; GripperError unless the answer is "<var> <integer>".
  int get(const std::string& var, std::chrono::milliseconds timeout);
  /// ACT 1, then STA polled until 3 (active) within `timeout`, then GTO 1 with full speed and `force`.
  void activate(int force, std::chrono::milliseconds timeout);
  void close();
  bool connected() const;

 private:
  struct Io;
  /// Sends `line` and returns the answer's line, without its newline; closes and throws on failure.
  std::string exchange(const std::string& line, std::chrono::milliseconds timeout);
  [[noreturn]] void fail(const std::string& why);
  std::unique_ptr<Io> io_;
};

/// The answer of the URCap's server to one request line (without its newline): "ack" to a SET of
/// variables `set` takes, "<VAR> <n>" to a GET of one `get` knows, "?" to anything else (this double's
/// answer; a URCap's to a bad line is not documented here).
std::string robotiq_answer(const std::string& line, const std::function<bool(const std::string&, int)>& set,
                           const std::function<std::optional<int>(const std::string&)>& get);

/// The URCap's server as a test double on 127.0.0.1, one client at a time, on a thread of its own.
class RobotiqServer {
 public:
  /// `set` takes a variable's new value (false: not a variable it knows); `get` gives one's value
  /// (nullopt: unknown). Both run on the server's thread. Port 0: one the system picks.
  RobotiqServer(std::function<bool(const std::string&, int)> set,
                std::function<std::optional<int>(const std::string&)> get, std::uint16_t port = 0);
  ~RobotiqServer();
  RobotiqServer(const RobotiqServer&) = delete;
  RobotiqServer& operator=(const RobotiqServer&) = delete;
  std::uint16_t port() const { return port_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::uint16_t port_ = 0;
};

}  // namespace dh::rtde
