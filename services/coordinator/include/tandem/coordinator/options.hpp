// tandem-coordinator's command line (CLI11, runtime::parse_args): no DDS, no file read; unit-tested from argv.
#pragma once

#include <string>
#include <vector>

namespace tandem::coordinator {

struct Options {
  std::string file;              ///< the deployment file (its coordinator section and modules)
  int domain = -1;               ///< DDS domain id
  double timeout = 30.0;         ///< give up after this long with no task finished [s]
  std::string id = "coordinator";  ///< process id in status
  bool standby = false;          ///< assign nothing until the primary falls silent
  bool resume = false;           ///< a queue existed before this one started: never take over without its state
};

/// Parses argv into `o`. Returns -1 to go on, else the exit code (0 after --help, 2 after a bad command line, said
/// on stderr or into `err` when given).
int parse_options(int argc, const char* const* argv, Options& o, std::string* err = nullptr);
/// The command line (without the program) that parse_options reads back as `o` (how the launcher starts a
/// coordinator; kept in step with the parser by a round-trip test).
std::vector<std::string> to_args(const Options& o);

}  // namespace tandem::coordinator
