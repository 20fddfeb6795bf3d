// Command lines of the role processes (world, robot, supervisor, coordinator), on CLI11 (libcli11-dev): one form of
// --help for all of them, checked values with messages that name the option and what it accepts. No DDS, no file
// read here: the options are parsed into plain structs that unit tests build from argv (tests/unit/test_args.cpp).
#pragma once

#include <string>

#include <CLI/CLI.hpp>

namespace tandem::runtime {

/// Parses argv with `app`. Returns -1 to go on; else the process's exit code: 0 after --help (printed to stdout),
/// 2 after a bad command line, said on stderr as "<program>: <what>; see --help" (the exit codes of
/// launcher/exit_codes.hpp). `err`, when given, receives what was said instead of stderr (for tests).
int parse_args(CLI::App& app, int argc, const char* const* argv, std::string* err = nullptr);

/// A DDS domain id option: an integer in [0, 232].
CLI::Option* add_domain(CLI::App& app, int& domain);

/// A check for a duration: a finite number of seconds in (0, max_s].
CLI::Validator seconds_up_to(double max_s);

}  // namespace tandem::runtime
