#include "tandem/runtime/args.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "tandem/launcher/exit_codes.hpp"

namespace tandem::runtime {

namespace {

template <class Parse>
int parse_with(CLI::App& app, std::string* err, Parse&& parse) {
  try {
    parse();
    return -1;
  } catch (const CLI::CallForHelp&) {
    std::fputs(app.help().c_str(), stdout);
    return launcher::exit_code::kDone;
  } catch (const CLI::ParseError& e) {
    std::string what = e.what();
    // An argument no option takes is said first, whatever else failed: it is most often a misspelt option,
    // and a "--out is required" beside "--uot" would send the user looking in the wrong place.
    if (!app.remaining().empty()) {
      std::string extras;
      for (const std::string& x : app.remaining()) extras += (extras.empty() ? "'" : ", '") + x + "'";
      what = "unknown option or extra argument " + extras;
    }
    const std::string line = app.get_name() + ": " + what + "; see --help\n";
    if (err != nullptr) {
      *err = line;
    } else {
      std::fputs(line.c_str(), stderr);
    }
    return launcher::exit_code::kBadArgs;
  }
}

}  // namespace

int parse_args(CLI::App& app, int argc, const char* const* argv, std::string* err) {
  return parse_with(app, err, [&] { app.parse(argc, argv); });
}

int parse_args(CLI::App& app, const std::vector<std::string>& args, std::string* err) {
  std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 takes the arguments last first
  return parse_with(app, err, [&] { app.parse(reversed); });
}

CLI::Validator one_of(const std::vector<std::string>& names) {
  std::string list;
  for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
  return CLI::Validator(
      [names, list](std::string& v) {
        for (const std::string& n : names) {
          if (v == n) return std::string();
        }
        return "'" + v + "' is not accepted; accepted: " + list;
      },
      "");
}

double parse_duration(const std::string& text) {
  if (text.empty()) return -1.0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || !std::isfinite(v) || v <= 0.0) return -1.0;
  const std::string unit(end);
  if (unit.empty() || unit == "s") return v;
  if (unit == "m" || unit == "min") return 60.0 * v;
  if (unit == "h") return 3600.0 * v;
  return -1.0;
}

CLI::Validator duration() {
  return CLI::Validator(
      [](std::string& v) {
        return parse_duration(v) > 0.0 ? std::string()
                                       : "'" + v + "': expected a time above 0 such as 90, 90s, 10m or 1h";
      },
      "");
}

CLI::Validator whole_number() {
  return CLI::Validator(
      [](std::string& v) {
        const bool ok = !v.empty() && v.find_first_not_of("0123456789") == std::string::npos && v.size() <= 19;
        return ok ? std::string() : "'" + v + "': expected a whole number >= 0";
      },
      "");
}

CLI::Validator decimal() {
  return CLI::Validator(
      [](std::string& v) {
        const bool digits = !v.empty() && v.find_first_not_of("0123456789") == std::string::npos;
        // CLI11 reads integers in base 0 (strtoll): "010" would be 8. Only plain decimal numbers are accepted.
        return digits && (v.size() == 1 || v[0] != '0') ? std::string()
                                                        : "'" + v + "' is not a whole number in decimal (no sign, no leading 0)";
      },
      "");
}

CLI::Option* add_domain(CLI::App& app, int& domain) {
  return app.add_option("--domain", domain, "DDS domain id")->check(decimal())->check(CLI::Range(0, 232))->type_name("ID");
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
