// The episode history the governor keeps and the slow brain reads: one line per dispatch and per command
// outcome. Outcome lines carry the command's arguments in a fixed form, so a planner can tell which steps
// of its plan completed, whichever capability completed them (a substitution keeps the arguments).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace dh::history {

using Args = std::vector<std::pair<std::string, std::string>>;

/// "[object=bowl target=plate]": roles sorted, so the same arguments always read the same.
std::string signature(Args args);
/// "step 120: pick_place completed [object=bowl target=plate]: reason" (": reason" only when given).
std::string outcome_line(std::uint32_t step, const std::string& capability, const std::string& outcome,
                         const Args& args, const std::string& reason);
/// Whether some command with exactly these arguments completed.
bool completed(const std::vector<std::string>& lines, const Args& args);

}  // namespace dh::history
