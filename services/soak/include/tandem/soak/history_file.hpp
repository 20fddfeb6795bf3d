// A soak run's whole recording as a file (history.pb in the report directory, schema idl/tandem_soak.proto):
// the History the checker judged and the RunInfo the report names, so that `tandem soak --judge DIR` can judge a
// recorded run again with a newer checker and write its report again, without running it again.
#pragma once

#include <string>

#include "tandem/soak/history.hpp"
#include "tandem/soak/report.hpp"

namespace tandem::soak {

/// Writes `info` and `h` to `path` (Protobuf, binary). Throws std::runtime_error naming the file if it cannot.
void save_history(const std::string& path, const RunInfo& info, const History& h);

/// Reads what save_history wrote. Throws std::runtime_error naming the file and what is wrong (missing, not a
/// soak history, a newer format, an event or fault kind this build does not know); `info` and `h` are then
/// unchanged.
void load_history(const std::string& path, RunInfo& info, History& h);

}  // namespace tandem::soak
