// Strict YAML loader for scenarios: unknown keys, wrong types, missing fields and out-of-range values are
// errors that name the file, the key path, the line, and what is accepted.
#pragma once

#include <stdexcept>
#include <string>

#include "tandem/sim/scenario.hpp"

namespace tandem::sim {

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The CSV file stem of a case: letters, digits and '-' kept, anything else mapped to '_'.
std::string file_name(const std::string& case_name);

/// Reads and validates a scenario file. Throws ConfigError.
Scenario load_scenario(const std::string& path);
/// Same, from YAML text; `source` names it in messages.
Scenario parse_scenario(const std::string& yaml_text, const std::string& source);

}  // namespace tandem::sim
