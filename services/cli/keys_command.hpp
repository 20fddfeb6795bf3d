// tandem keys: the DDS-Security keys of a deployment (docs/security.md).
#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace tandem::cli {

int keys_command(const std::vector<std::string>& args);
void keys_usage(std::FILE* f);

}  // namespace tandem::cli
