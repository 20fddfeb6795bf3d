#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace tandem::cli {
void soak_usage(std::FILE* f);
int soak_command(const std::vector<std::string>& args);
}  // namespace tandem::cli
