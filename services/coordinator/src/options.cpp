#include "tandem/coordinator/options.hpp"

#include <cstdio>

#include "tandem/runtime/args.hpp"

namespace tandem::coordinator {

int parse_options(int argc, const char* const* argv, Options& o, std::string* err) {
  CLI::App app("The high-level coordinator over a deployment's modules (started by 'tandem up' for deployments\n"
               "with a coordinator section): it keeps the task queue and hands each task to a free module.",
               "tandem-coordinator");
  app.add_option("--deployment-file", o.file, "the deployment file")->required()->type_name("FILE");
  runtime::add_domain(app, o.domain)->required();
  app.add_option("--timeout", o.timeout, "give up after this long with no task finished")
      ->check(runtime::seconds_up_to(86400.0))->capture_default_str()->type_name("SECONDS");
  app.add_option("--id", o.id, "process id in status")
      ->check(CLI::Validator([](std::string& v) { return v.empty() ? std::string("an empty id") : std::string(); },
                             ""))
      ->capture_default_str()->type_name("NAME");
  app.add_flag("--standby", o.standby, "assign nothing until the primary falls silent, then take over its queue");
  app.add_flag("--resume", o.resume, "a restart: take over only with a queue state heard, never with a fresh queue");
  app.footer("Exit: 0 every task done or stopped, 1 a task done twice, 2 bad arguments or deployment, 3 left after a\n"
             "stall (another one leads), 4 no progress, 6 cut off: a restart (--resume) that heard no queue state in\n"
             "10 s, or a primary that heard no module for 10 s while another coordinator lives.");
  return runtime::parse_args(app, argc, argv, err);
}

std::vector<std::string> to_args(const Options& o) {
  char timeout[32];
  std::snprintf(timeout, sizeof timeout, "%.17g", o.timeout);
  std::vector<std::string> a{"--deployment-file", o.file, "--domain", std::to_string(o.domain), "--timeout", timeout,
                             "--id", o.id};
  if (o.standby) a.emplace_back("--standby");
  if (o.resume) a.emplace_back("--resume");
  return a;
}

}  // namespace tandem::coordinator
