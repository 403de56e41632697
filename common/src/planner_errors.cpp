#include "dh/common/planner_errors.hpp"

#include <random>

#include <fmt/format.h>

#include "dh/common/config.hpp"
#include "dh/common/digest.hpp"

namespace dh {

const char* to_string(PlannerError e) {
  switch (e) {
    case PlannerError::None: return "none";
    case PlannerError::WrongCapability: return "wrong_capability";
    case PlannerError::WrongArgument: return "wrong_argument";
    case PlannerError::DroppedStep: return "dropped_step";
    case PlannerError::RepeatedStep: return "repeated_step";
  }
  return "?";
}

std::string PlannerErrorRates::text() const {
  return fmt::format("wrong_capability {:g}, wrong_argument {:g}, dropped_step {:g}, repeated_step {:g}",
                     wrong_capability, wrong_argument, dropped_step, repeated_step);
}

std::uint64_t planner_error_seed(const std::string& cell, std::uint32_t task, std::uint64_t seed) {
  const std::string key = cell + "/" + std::to_string(task) + "/" + std::to_string(seed);
  return fnv1a64(key.data(), key.size());
}

PlannerErrorDraw draw_planner_error(const PlannerErrorRates& rates, std::uint64_t seed, std::uint32_t index) {
  // A stream of its own per (seed, request): independent of every other draw of the episode.
  std::seed_seq seq{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32), index, 0x706c6eu};
  std::mt19937_64 rng(seq);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double x = u(rng);
  PlannerErrorDraw d;
  d.pick = u(rng);
  double at = 0;
  const std::pair<double, PlannerError> kinds[] = {{rates.wrong_capability, PlannerError::WrongCapability},
                                                   {rates.wrong_argument, PlannerError::WrongArgument},
                                                   {rates.dropped_step, PlannerError::DroppedStep},
                                                   {rates.repeated_step, PlannerError::RepeatedStep}};
  for (const auto& [rate, kind] : kinds) {
    at += rate;
    if (x < at) {
      d.error = kind;
      break;
    }
  }
  return d;
}

PlannerErrorRates load_planner_errors(const std::filesystem::path& file, const std::string& name) {
  const ConfigNode root = ConfigNode::load_file(file);
  const ConfigNode profiles = root.child("profiles");
  if (!profiles.has(name)) {
    std::string known;
    for (const auto& k : profiles.keys()) known += (known.empty() ? "" : ", ") + k;
    profiles.fail(name, "no planner-error profile '" + name + "' (profiles: " + known + ")");
  }
  const ConfigNode p = profiles.child(name);
  PlannerErrorRates r{p.get_or<double>("wrong_capability", 0), p.get_or<double>("wrong_argument", 0),
                      p.get_or<double>("dropped_step", 0), p.get_or<double>("repeated_step", 0)};
  for (const double x : {r.wrong_capability, r.wrong_argument, r.dropped_step, r.repeated_step})
    if (!(x >= 0 && x <= 1)) p.fail("", "each rate is a probability in [0, 1]");
  if (r.total() > 1 + 1e-12) p.fail("", "the rates sum to " + std::to_string(r.total()) + ", above 1");
  return r;
}

}  // namespace dh
