#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace tandem::cli {
void sim_usage(std::FILE* f);
int sim_command(const std::vector<std::string>& args);
}  // namespace tandem::cli
