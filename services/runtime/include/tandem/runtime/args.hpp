// Command lines of the role processes (world, robot, supervisor, coordinator), on CLI11 (libcli11-dev): one form of
// --help for all of them, checked values with messages that name the option and what it accepts. No DDS, no file
// read here: the options are parsed into plain structs that unit tests build from argv (tests/unit/test_args.cpp).
#pragma once

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace tandem::runtime {

/// Parses argv with `app`. Returns -1 to go on; else the process's exit code: 0 after --help (printed to stdout),
/// 2 after a bad command line, said on stderr as "<program>: <what>; see --help" (the exit codes of
/// launcher/exit_codes.hpp). An argument that no option takes is said as "unknown option or extra argument
/// '<it>'". `err`, when given, receives what was said instead of stderr (for tests).
int parse_args(CLI::App& app, int argc, const char* const* argv, std::string* err = nullptr);

/// The same for a `tandem` subcommand's arguments (argv without the program and the command): `app`'s name is
/// the "tandem <command>" that messages start with.
int parse_args(CLI::App& app, const std::vector<std::string>& args, std::string* err = nullptr);

/// A check that the value is one of `names`; its message names the value and what is accepted.
CLI::Validator one_of(const std::vector<std::string>& names);

/// "90", "90s", "10m", "1h", "1.5m" -> seconds; -1 if malformed or not above 0.
double parse_duration(const std::string& text);
/// A check for such a duration.
CLI::Validator duration();
/// A check for a whole number >= 0 (no sign, no fraction).
CLI::Validator whole_number();

/// A check for a plain decimal whole number (CLI11 itself reads "010" as 8).
CLI::Validator decimal();

/// A DDS domain id option: an integer in [0, 232].
CLI::Option* add_domain(CLI::App& app, int& domain);

/// A check for a duration: a finite number of seconds in (0, max_s].
CLI::Validator seconds_up_to(double max_s);

}  // namespace tandem::runtime
