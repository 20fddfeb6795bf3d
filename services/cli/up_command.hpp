#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace tandem::cli {
void up_usage(std::FILE* f);
int up_command(const std::vector<std::string>& args);
/// The directory of the running `tandem` executable (its sibling executables live there).
std::string self_dir();
}  // namespace tandem::cli
