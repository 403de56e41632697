// The planner's core, DDS-free (DESIGN §11): it takes plan requests and capability announcements and
// returns what to publish. The rules backend answers at once. A model backend's requests become jobs run
// elsewhere (the DDS shell's worker pool), at most one live per channel: a newer request for a channel
// cancels the older job, whose answer is then dropped, because the governor waits only for its latest
// request per channel. Every answer carries the planner error the request's rates draw for it (errors.hpp),
// whichever backend gave the advice. The DDS shell (node/planner_node.cpp) and the in-process bus both run
// it.
#pragma once

#include <atomic>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "dh/common/planner_errors.hpp"
#include "dh/common/ports.hpp"
#include "dh/planner/rules.hpp"

namespace dh::planner {

/// A plan request (the IDL PlanRequest's fields, DDS-free).
struct Request {
  std::uint32_t channel = 0;
  std::string request_id, episode_id;
  PlanContext context;
  std::uint64_t seed = 0;    ///< the error draws' (planner_error_seed)
  std::uint32_t index = 0;   ///< the request's number in its episode
  PlannerErrorRates errors;  ///< all 0: none
};

/// What to publish for a request: the backend's advice, made wrong as the request's draw says.
struct Answer {
  std::uint32_t channel = 0;
  std::string request_id, episode_id;
  PlannerAdvice advice;
  PlannerError injected = PlannerError::None;
};

/// A request for the model backend, run off the core's thread. `cancelled` turns true once a newer request
/// for its channel supersedes it (or the core is stopped): the worker may give up, and its answer is dropped.
struct Job {
  Request request;
  CapabilityRoles roles;  ///< as announced when the request arrived
  std::shared_ptr<const std::atomic<bool>> cancelled;
};

class PlannerCore {
 public:
  enum class Backend { Rules, Model };

  explicit PlannerCore(Backend backend) : backend_(backend) {}
  ~PlannerCore();
  PlannerCore(const PlannerCore&) = delete;
  PlannerCore& operator=(const PlannerCore&) = delete;

  /// What the service reads and writes (README.md lists them; a test checks the list).
  static const Ports& ports();

  void on_announce(const std::string& capability, std::vector<std::string> roles);
  /// Rules: the answer now. Model: the job to run, cancelling the channel's older job.
  std::variant<Answer, Job> on_request(Request r);
  /// The model's advice for `job`: the answer, or nullopt when the job was superseded meanwhile.
  std::optional<Answer> on_advice(const Job& job, PlannerAdvice advice);
  /// Cancels every live job (the service stops).
  void stop();

  const CapabilityRoles& roles() const { return roles_; }

 private:
  Backend backend_;
  CapabilityRoles roles_;
  std::map<std::uint32_t, std::shared_ptr<std::atomic<bool>>> live_;  ///< per channel, its latest job's flag
};

}  // namespace dh::planner
