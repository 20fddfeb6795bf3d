// tandem view: a running deployment in the browser and in Foxglove Studio (docs/view.md).
#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace tandem::cli {

int view_command(const std::vector<std::string>& args);
void view_usage(std::FILE* f);

}  // namespace tandem::cli
