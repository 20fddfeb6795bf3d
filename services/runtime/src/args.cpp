#include "tandem/runtime/args.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "tandem/launcher/exit_codes.hpp"

namespace tandem::runtime {

int parse_args(CLI::App& app, int argc, const char* const* argv, std::string* err) {
  try {
    app.parse(argc, argv);
    return -1;
  } catch (const CLI::CallForHelp&) {
    std::fputs(app.help().c_str(), stdout);
    return launcher::exit_code::kDone;
  } catch (const CLI::ParseError& e) {
    const std::string line = app.get_name() + ": " + e.what() + "; see --help\n";
    if (err != nullptr) {
      *err = line;
    } else {
      std::fputs(line.c_str(), stderr);
    }
    return launcher::exit_code::kBadArgs;
  }
}

CLI::Option* add_domain(CLI::App& app, int& domain) {
  return app.add_option("--domain", domain, "DDS domain id")->check(CLI::Range(0, 232))->type_name("ID");
}

CLI::Validator seconds_up_to(double max_s) {
  return CLI::Validator(
      [max_s](std::string& v) {
        char* end = nullptr;
        const double x = std::strtod(v.c_str(), &end);
        if (v.empty() || *end != '\0' || !std::isfinite(x) || x <= 0.0 || x > max_s) {
          char line[96];
          std::snprintf(line, sizeof line, "must be a number of seconds in (0, %g], got '", max_s);
          return std::string(line) + v + "'";
        }
        return std::string();
      },
      "");
}

}  // namespace tandem::runtime
