// Wall-clock stamps for ids and records.
#pragma once

#include <string>

namespace dh {

/// The current UTC time formatted by strftime(`format`), e.g. "%Y-%m-%dT%H:%M:%SZ".
std::string utc_time(const char* format);

/// "<UTC yyyymmddThhmmss>-<pid>": unique to this process run, for ids that must not repeat across runs.
std::string run_tag();

}  // namespace dh
