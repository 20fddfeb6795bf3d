// Writing the files of a report or a run (soak reports, recording reports, `tandem sim` output, `tandem keys`):
// one place for the directory and file helpers the commands share.
#pragma once

#include <string>
#include <sys/types.h>

namespace tandem::page {

/// Creates `path` and its missing parents with `mode` (existing ones are left as they are). False if one cannot
/// be created; errno says why.
bool make_dirs(const std::string& path, mode_t mode = 0755);

/// Writes `text` to `path` (truncated). Throws std::runtime_error("cannot write <path>") on failure.
void write_file(const std::string& path, const std::string& text);

}  // namespace tandem::page
