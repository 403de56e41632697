#include "dh/common/service.hpp"

#include <exception>

namespace dh {

int run_managed(spdlog::logger& log, ManagedService service) {
  install_shutdown_handlers();
  Lifecycle life(std::move(service.transitions));
  const auto go = [&](LifecycleTransition t) {
    const TransitionResult r = life.trigger(t);
    if (r.ok)
      log.info("lifecycle: {} ({} -> {})", to_string(t), to_string(r.from), to_string(r.to));
    else
      log.error("lifecycle: {} failed in state {}: {}", to_string(t), to_string(r.from), r.reason);
    return r.ok;
  };
  bool ok = go(LifecycleTransition::Configure) && go(LifecycleTransition::Activate);
  if (ok) {
    try {
      while (!shutdown_requested()) service.step();
      if (!go(LifecycleTransition::Drain)) {
        ok = false;
      } else if (service.drained) {
        const auto until = std::chrono::steady_clock::now() + service.drain_timeout;
        while (!service.drained() && std::chrono::steady_clock::now() < until) service.step();
        if (!service.drained())
          log.warn("lifecycle: drain did not finish within {} ms", service.drain_timeout.count());
      }
    } catch (const std::exception& e) {
      log.error("{}", e.what());
      ok = false;
    }
    ok = go(LifecycleTransition::Deactivate) && ok;
  }
  ok = go(LifecycleTransition::Shutdown) && ok;
  return ok ? 0 : 1;
}

}  // namespace dh
