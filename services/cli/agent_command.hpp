#pragma once

#include <string>
#include <vector>

namespace tandem::cli {
/// `tandem agent`: the per-host agent of a multi-host deployment (docs/multihost.md).
int agent_command(const std::vector<std::string>& args);
}  // namespace tandem::cli
