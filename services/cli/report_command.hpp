// tandem report: an HTML page with plots of a recording (docs/recording.md).
#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace tandem::cli {

int report_command(const std::vector<std::string>& args);
void report_usage(std::FILE* f);

}  // namespace tandem::cli
