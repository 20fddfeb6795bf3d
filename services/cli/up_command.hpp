#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "tandem/launcher/spawn.hpp"

namespace tandem::cli {
void up_usage(std::FILE* f);
int up_command(const std::vector<std::string>& args);
/// The directory of the running `tandem` executable (its sibling executables live there).
inline std::string self_dir() { return launcher::self_dir(); }
}  // namespace tandem::cli
