// An episode page's data, from its evidence file: what was asked, and on the step axis the advisories,
// groundings (with θ), refusals with their reasons, dispatches, decisions other than "continue"
// (recoveries and hand-overs to vla_act among them), command ends, verdict changes and the end; for a
// failed episode, its attribution layer (configs/attribution.yaml).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>

namespace dh::view {

/// {episode_id, arm, cell, suite, task, seed, instruction, budget_steps, library_version, end_step, outcome,
///  reason, success, latched, verdict_step, safety_holds, attribution: {layer, name, harness, capability,
///  failure, stage, step} or null, events: [{step, kind, ...}]}; kind is advice, grounding, refusal,
///  dispatch, decision, command_end, verdict or end. Throws std::runtime_error naming the file when it is
///  missing, is not a governor's evidence, or holds no record.
nlohmann::json episode_timeline(const std::filesystem::path& evidence, const std::filesystem::path& attribution_config);

}  // namespace dh::view
