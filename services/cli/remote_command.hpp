#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace tandem::cli {
void remote_usage(std::FILE* f);
int status_command(const std::vector<std::string>& args);
int down_command(const std::vector<std::string>& args);
int kill_command(const std::vector<std::string>& args);
int plug_command(const std::vector<std::string>& args);
int unplug_command(const std::vector<std::string>& args);
}  // namespace tandem::cli
