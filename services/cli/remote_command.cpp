// `tandem status` and `tandem down`: talk to a running deployment over DDS, from any terminal.
#include "remote_command.hpp"

#include <tandemPubSubTypes.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>

#include "tandem/runtime/deployment.hpp"
#include "tandem/runtime/role.hpp"
#include "live_view.hpp"
#include "tandem/dds/bus.hpp"

namespace tandem::cli {
using runtime::Deployment;
using runtime::load_deployment;
namespace {
namespace bus = tandem::dds;

// Target: a deployment file (its name, domain and transport), or --domain ID [--name NAME].
bool parse_target(const char* cmd, const std::vector<std::string>& args, Deployment& d) {
  bool have = false;
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--domain" && i + 1 < args.size()) {
      if (!runtime::parse_domain(args[++i], d.domain_id)) {
        std::fprintf(stderr, "tandem %s: --domain must be an integer in [0, 232], got '%s'\n", cmd, args[i].c_str());
        return false;
      }
      have = true;
    } else if (args[i] == "--name" && i + 1 < args.size()) {
      d.name = args[++i];
    } else if (!args[i].empty() && args[i][0] != '-') {
      try {
        d = load_deployment(args[i]);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "tandem %s: %s\n", cmd, e.what());
        return false;
      }
      have = true;
    } else {
      std::fprintf(stderr, "tandem %s: unknown option '%s'\n", cmd, args[i].c_str());
      return false;
    }
  }
  if (!have) std::fprintf(stderr, "tandem %s: give a deployment file, or --domain ID [--name NAME]\n", cmd);
  return have;
}
}  // namespace

void remote_usage(std::FILE* f) {
  std::fputs(
      "usage: tandem status <deploy.yaml> | --domain ID [--name NAME]\n"
      "       tandem down   <deploy.yaml> | --domain ID --name NAME\n"
      "       tandem kill   <deploy.yaml> | --domain ID --name NAME  PROCESS\n"
      "status: prints the lifecycle state and live figures of every process of the deployment(s) on the domain.\n"
      "down:   asks the deployment's launcher to stop it cleanly (as Ctrl-C would); exit 1 if no launcher on the\n"
      "        domain is listening (a launcher of another deployment on the same domain ignores the request).\n"
      "kill:   fault injection: the launcher SIGKILLs PROCESS (a label of its live view, e.g. m1/left); the\n"
      "        launcher prints whether that process was running.\n",
      f);
}

int status_command(const std::vector<std::string>& args) {
  Deployment d;
  if (!parse_target("status", args, d)) return 2;
  bus::Participant part(d.domain_id, "tandem-status", runtime::transport_of(d));
  bus::Reader<msg::ProcessStatus, msg::ProcessStatusPubSubType> status(part, bus::kStatusTopic, bus::TopicKind::Status);
  LiveView view(d.name);
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - t0 < std::chrono::milliseconds(1500)) {
    status.wait(0.1);
    msg::ProcessStatus s;
    while (status.take(s)) view.update(s);
  }
  if (view.size() == 0) {
    std::printf("no process of %s on domain %d\n", d.name.empty() ? "any deployment" : d.name.c_str(), d.domain_id);
    return 1;
  }
  std::printf("%s on domain %d:\n", d.name.empty() ? "deployments" : d.name.c_str(), d.domain_id);
  view.print(stdout);
  return 0;
}

namespace {
int send_request(const char* verb, const Deployment& d, const std::string& target) {
  if (d.name.empty()) {
    std::fprintf(stderr, "tandem %s: name the deployment (--name NAME or a deployment file)\n", verb);
    return 2;
  }
  bus::Participant part(d.domain_id, "tandem-down", runtime::transport_of(d));
  bus::Writer<msg::ControlRequest, msg::ControlRequestPubSubType> control(part, bus::kControlTopic, bus::TopicKind::Control);
  const auto t0 = std::chrono::steady_clock::now();
  while (control.matched() < 1 && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(3)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (control.matched() < 1) {
    std::fprintf(stderr, "tandem %s: no launcher on domain %d answered\n", verb, d.domain_id);
    return 1;
  }
  msg::ControlRequest req;
  req.deployment(d.name);
  req.command(verb);
  req.target(target);
  req.seq(1);
  control.write(req);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // let it be delivered
  if (target.empty()) {
    std::printf("asked %s on domain %d to stop\n", d.name.c_str(), d.domain_id);
  } else {
    std::printf("asked %s on domain %d to %s %s\n", d.name.c_str(), d.domain_id, verb, target.c_str());
  }
  return 0;
}
}  // namespace

int down_command(const std::vector<std::string>& args) {
  Deployment d;
  if (!parse_target("down", args, d)) return 2;
  return send_request("down", d, "");
}

int kill_command(const std::vector<std::string>& args) {
  if (args.empty()) {
    remote_usage(stderr);
    return 2;
  }
  const std::string target = args.back();
  Deployment d;
  if (!parse_target("kill", std::vector<std::string>(args.begin(), args.end() - 1), d)) return 2;
  return send_request("kill", d, target);
}

}  // namespace tandem::cli
