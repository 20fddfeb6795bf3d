// tandem record: writes a deployment's topics to an MCAP file (docs/recording.md).
#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace tandem::cli {

int record_command(const std::vector<std::string>& args);
void record_usage(std::FILE* f);

}  // namespace tandem::cli
