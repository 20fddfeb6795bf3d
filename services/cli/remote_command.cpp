// `tandem status` and `tandem down`: talk to a running deployment over DDS, from any terminal.
#include "remote_command.hpp"

#include <tandemPubSubTypes.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>

#include <unistd.h>

#include "tandem/launcher/spawn.hpp"
#include "tandem/runtime/args.hpp"
#include "tandem/runtime/deployment.hpp"
#include "tandem/runtime/role.hpp"
#include "tandem/runtime/security.hpp"
#include "live_view.hpp"
#include "tandem/dds/bus.hpp"

namespace tandem::cli {
using runtime::Deployment;
using runtime::load_deployment;
namespace {
namespace bus = tandem::dds;

const char* const kRemoteHelp =
    "status: prints the lifecycle state and live figures of every process of the deployment(s) on the domain;\n"
    "        with a launcher, it waits (at most 10 s) until every process the launcher runs has been heard.\n"
    "down:   asks the deployment's launcher to stop it cleanly (as Ctrl-C would) and prints its answer; exit 1\n"
    "        if no launcher of that deployment answers.\n"
    "kill:   fault injection: the launcher SIGKILLs PROCESS (a label of the status view, e.g. m1/left, m1/world,\n"
    "        m1/supervisor, m1/supervisor@50, coordinator) or every process of a MODULE. A robot or supervisor\n"
    "        with a standby is replaced at once; see docs/failure-model.md for what happens to the others.\n"
    "plug robot: starts a robot process for the arm, as its primary (default; refused if the arm has one) or as\n"
    "        a standby computing in shadow. Plugged into a paused module (arm braked), it releases the brake and\n"
    "        the module resumes.\n"
    "plug module: starts a module of the deployment file not yet running (autostart: false), or a new one\n"
    "        with --scenario and --case (and --host, a host of the deployment's hosts:, in a multi-host\n"
    "        deployment); the coordinator gives it tasks.\n"
    "unplug robot: graceful. With another robot on the arm, it hands over at once (its writer is deleted\n"
    "        first). Without, the module pauses (object brought to rest, the arm braked) until a robot is plugged.\n"
    "unplug module: the module finishes its task, takes no new one, and its processes stop.\n"
    "down, kill, plug and unplug wait for the launcher's answer and print it: exit 0 done, 1 refused or no\n"
    "answer, 2 bad command line.";

/// A live command's command line: its target (a deployment file, or --domain ID [--name NAME]) and its words.
struct RemoteArgs {
  std::vector<std::string> words;  ///< the deployment file first (unless --domain), then the command's own words
  int domain = -1;
  std::string name;
  bool standby = false, primary = false;  // plug robot
  std::string scenario, case_name, host;  // plug module
};

/// The command line of `tandem <verb>`, on CLI11 (runtime::parse_args).
void describe(CLI::App& app, RemoteArgs& a, const std::string& verb) {
  const bool plug = verb == "plug", unplug = verb == "unplug";
  std::string words = "DEPLOY.yaml";
  if (verb == "kill") words += " PROCESS|MODULE";
  if (plug) words += " robot MODULE/ARM | module NAME";
  if (unplug) words += " robot MODULE/ARM[@STRENGTH] | module NAME";
  app.description("tandem " + verb + ": a live command to a running deployment, over DDS.");
  app.add_option("words", a.words, "the deployment file (none with --domain), then what the command acts on")
      ->type_name(words);
  app.add_option("--domain", a.domain, "the DDS domain of a deployment given without its file")
      ->check(runtime::decimal())->check(CLI::Range(0, 232))->type_name("ID");
  app.add_option("--name", a.name, "the deployment's name (with --domain)")->type_name("NAME");
  if (plug) {
    app.add_flag("--standby", a.standby, "plug robot: as a standby computing in shadow");
    app.add_flag("--primary", a.primary, "plug robot: as the arm's primary (the default)");
    app.add_option("--scenario", a.scenario, "plug module: a new module's scenario")->type_name("FILE");
    app.add_option("--case", a.case_name, "plug module: the case of that scenario")->type_name("CASE");
    app.add_option("--host", a.host, "plug module: the host of a multi-host deployment to start it on")->type_name("H");
  }
  app.footer(kRemoteHelp);
}

/// The target of `a` into `d` (the file loaded, or --domain and --name), and the remaining words; false (said)
/// if there is none or the file is bad.
bool resolve_target(const char* cmd, const RemoteArgs& a, Deployment& d, std::vector<std::string>& rest) {
  rest = a.words;
  // The first word is the deployment file unless --domain names the target; a .yaml/.yml file with --domain is
  // still loaded, and --domain and --name override what it says.
  const auto yaml = [](const std::string& w) {
    return (w.size() > 5 && w.compare(w.size() - 5, 5, ".yaml") == 0) || (w.size() > 4 && w.compare(w.size() - 4, 4, ".yml") == 0);
  };
  if (!rest.empty() && (a.domain < 0 || yaml(rest.front()))) {
    try {
      d = load_deployment(rest.front());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "tandem %s: %s\n", cmd, e.what());
      return false;
    }
    rest.erase(rest.begin());
  } else if (a.domain < 0) {
    std::fprintf(stderr, "tandem %s: give a deployment file, or --domain ID [--name NAME]\n", cmd);
    return false;
  }
  if (a.domain >= 0) d.domain_id = a.domain;
  if (!a.name.empty()) d.name = a.name;
  return true;
}

/// Parses `args` for `tandem <verb>`; -1 to go on (the target in `d`, the command's own words in `rest`), else
/// the exit code.
int parse_remote(const std::string& verb, const std::vector<std::string>& args, RemoteArgs& a, Deployment& d,
                 std::vector<std::string>& rest) {
  CLI::App app("", "tandem " + verb);
  describe(app, a, verb);
  if (const int code = runtime::parse_args(app, args); code >= 0) return code;
  return resolve_target(verb.c_str(), a, d, rest) ? -1 : 2;
}

}  // namespace

void remote_usage(std::FILE* f) {
  std::fputs(
      "usage: tandem status <deploy.yaml> | --domain ID [--name NAME]\n"
      "       tandem down   <deploy.yaml> | --domain ID --name NAME\n"
      "       tandem kill   <deploy.yaml> | --domain ID --name NAME  PROCESS\n"
      "       tandem plug   <deploy.yaml> | --domain ID --name NAME  robot MODULE/ARM [--standby | --primary]\n"
      "       tandem plug   <deploy.yaml> | --domain ID --name NAME  module NAME [--scenario FILE --case CASE [--host H]]\n"
      "       tandem unplug <deploy.yaml> | --domain ID --name NAME  robot MODULE/ARM[@STRENGTH] | module NAME\n",
      f);
  std::fputs(kRemoteHelp, f);
  std::fputs("\n('tandem <command> --help': the options of one command)\n", f);
}

int status_command(const std::vector<std::string>& args) {
  Deployment d;
  RemoteArgs a;
  std::vector<std::string> rest;
  if (const int code = parse_remote("status", args, a, d, rest); code >= 0) return code;
  if (!rest.empty()) {
    std::fprintf(stderr, "tandem status: unexpected '%s' (one deployment file, or --domain ID [--name NAME])\n",
                 rest.front().c_str());
    return 2;
  }
  runtime::use_discovery(d);
  if (const std::string err = runtime::use_security(d, "cli"); !err.empty()) {
    std::fprintf(stderr, "tandem status: %s\n", err.c_str());
    return 2;
  }
  std::string why;
  (void)launcher::raise_service_priority(why);  // as a live command (below)
  bus::Participant part(d.domain_id, "tandem-status", runtime::transport_of(d));
  bus::Reader<msg::ProcessStatus, msg::ProcessStatusPubSubType> status(part, bus::kStatusTopic, bus::TopicKind::Status);
  LiveView view(d.name);
  // The launcher lists the processes it runs: listen until every one of them has been heard (discovery on a
  // busy machine takes a while), at most 10 s. Without a launcher (a deployment started otherwise, or
  // every deployment on the domain): at least 1.5 s, then until nobody new has shown up for 0.5 s.
  const auto t0 = std::chrono::steady_clock::now();
  auto last_new = t0;
  while (true) {
    const auto now = std::chrono::steady_clock::now();
    if (now - t0 > std::chrono::seconds(10)) break;
    if (view.has_launcher() && !d.name.empty()) {
      if (view.missing().empty()) break;
    } else if (now - t0 > std::chrono::milliseconds(1500) && view.size() > 0 &&
               now - last_new > std::chrono::milliseconds(500)) {
      break;
    }
    status.wait(0.1);
    msg::ProcessStatus s;
    while (status.take(s)) {
      const size_t before = view.size();
      view.update(s);
      if (view.size() > before) last_new = std::chrono::steady_clock::now();
    }
  }
  if (view.size() == 0) {
    std::printf("no process of %s on domain %d\n", d.name.empty() ? "any deployment" : d.name.c_str(), d.domain_id);
    return 1;
  }
  std::printf("%s on domain %d:\n", d.name.empty() ? "deployments" : d.name.c_str(), d.domain_id);
  view.print(stdout, LiveView::Rows::Run);
  for (const auto& label : view.missing()) {
    std::printf("  %-18s not heard from within 10 s (started by the launcher; still starting, or stuck)\n",
                label.c_str());
  }
  return 0;
}

namespace {
// Sends a request to the deployment's launcher, re-sent until answered; waits up to 5 s for the launcher's answer
// (its status: reply_seq, reply_ok, reply_text), prints it, and returns 0 for ok, 1 for an error.
int send_request(const char* verb, const Deployment& d, msg::ControlRequest req) {
  if (d.name.empty()) {
    std::fprintf(stderr, "tandem %s: name the deployment (--name NAME or a deployment file)\n", verb);
    return 2;
  }
  runtime::use_discovery(d);
  if (const std::string err = runtime::use_security(d, "cli"); !err.empty()) {
    std::fprintf(stderr, "tandem %s: %s\n", verb, err.c_str());
    return 2;
  }
  // A live command is part of the control plane: ahead of a lockstep deployment's per-tick work, which fills every
  // core (a drain test's `tandem unplug` found no launcher within 10 s beside it), where permitted; before any
  // thread exists, so that Fast DDS's threads inherit it.
  std::string why;
  (void)launcher::raise_service_priority(why);
  bus::Participant part(d.domain_id, std::string("tandem-") + verb, runtime::transport_of(d));
  bus::Writer<msg::ControlRequest, msg::ControlRequestPubSubType> control(part, bus::kControlTopic, bus::TopicKind::Control);
  bus::Reader<msg::ProcessStatus, msg::ProcessStatusPubSubType> status(part, bus::kStatusTopic, bus::TopicKind::Status);
  // Wait until this deployment's launcher is heard (its status), so the request does not go out before the
  // launcher's reader has matched (supervisors read the same topic, so a match alone proves nothing).
  const auto t0 = std::chrono::steady_clock::now();
  bool launcher_seen = false;
  // Up to 10 s: discovery of a new participant took over 4 s now and then while a lockstep deployment kept
  // both cores busy.
  // The launcher's status can arrive before this writer has matched a reader of the control topic: wait for
  // both (a request written before any match is lost; later ones are re-sent until answered).
  while ((!launcher_seen || control.matched() < 1) && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(10)) {
    status.wait(0.05);
    msg::ProcessStatus s;
    while (status.take(s)) launcher_seen = launcher_seen || (s.deployment() == d.name && s.role() == "launcher");
  }
  if (!launcher_seen || control.matched() < 1) {
    std::fprintf(stderr, "tandem %s: no launcher of %s on domain %d answered within 10 s\n", verb, d.name.c_str(),
                 d.domain_id);
    return 1;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  req.deployment(d.name);
  // A sequence number unique enough to tell this request's answer from an earlier one; the launcher carries
  // a request out once, however often it arrives (it is re-sent until answered). The time in microseconds
  // and this process's pid: two CLIs started together got the same microsecond once, and the launcher took
  // the second request for a re-send of the first (a `plug` answered with a `down`'s reply).
  const auto us = static_cast<unsigned long long>(
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch()).count());
  const auto seq = us * 1000ULL + static_cast<unsigned long long>(::getpid()) % 1000ULL;
  req.seq(seq);
  control.write(req);
  const auto t1 = std::chrono::steady_clock::now();
  auto sent = t1;
  while (std::chrono::steady_clock::now() - t1 < std::chrono::seconds(5)) {
    if (std::chrono::steady_clock::now() - sent > std::chrono::milliseconds(500)) {
      control.write(req);
      sent = std::chrono::steady_clock::now();
    }
    status.wait(0.05);
    msg::ProcessStatus s;
    while (status.take(s)) {
      if (s.deployment() != d.name || s.role() != "launcher" || s.reply_seq() != seq) continue;
      std::printf("%s: %s\n", d.name.c_str(), s.reply_text().c_str());
      return s.reply_ok() ? 0 : 1;
    }
  }
  std::fprintf(stderr, "tandem %s: the launcher of %s did not answer within 5 s\n", verb, d.name.c_str());
  return 1;
}

}  // namespace

int down_command(const std::vector<std::string>& args) {
  Deployment d;
  RemoteArgs a;
  std::vector<std::string> rest;
  if (const int code = parse_remote("down", args, a, d, rest); code >= 0) return code;
  if (!rest.empty()) {
    std::fprintf(stderr, "tandem down: unexpected '%s' (one deployment file, or --domain ID --name NAME)\n",
                 rest.front().c_str());
    return 2;
  }
  msg::ControlRequest req;
  req.command(msg::CMD_DOWN);
  return send_request("down", d, req);
}

int kill_command(const std::vector<std::string>& args_in) {
  Deployment d;
  RemoteArgs a;
  std::vector<std::string> args;
  if (const int code = parse_remote("kill", args_in, a, d, args); code >= 0) return code;
  if (args.size() != 1 || args[0].empty()) {
    std::fprintf(stderr, "tandem kill: name one process (e.g. m1/left, m1/left@50, m2/world, coordinator) or module\n");
    return 2;
  }
  msg::ControlRequest req;
  req.command(msg::CMD_KILL);
  req.target_kind(args[0].find('/') == std::string::npos && args[0].rfind("coordinator", 0) != 0 ? msg::TARGET_MODULE
                                                                                                : msg::TARGET_PROCESS);
  req.target(args[0]);
  return send_request("kill", d, req);
}

namespace {
int plug_or_unplug(const char* verb, const std::vector<std::string>& args_in) {
  Deployment d;
  RemoteArgs a;
  std::vector<std::string> args;
  if (const int code = parse_remote(verb, args_in, a, d, args); code >= 0) return code;
  auto bad = [&](const std::string& why) {
    std::fprintf(stderr, "tandem %s: %s; see 'tandem %s --help'\n", verb, why.c_str(), verb);
    return 2;
  };
  if (args.size() < 2 || (args[0] != "robot" && args[0] != "module")) return bad("expected 'robot <label>' or 'module <name>'");
  if (args.size() > 2) return bad("unexpected '" + args[2] + "'");
  const bool plug = std::string(verb) == "plug";
  const bool robot = args[0] == "robot";
  const std::string name = args[1];
  std::string scenario = a.scenario;
  const std::string& case_name = a.case_name;
  const std::string& host = a.host;
  const bool standby = a.standby;
  if (a.standby && a.primary) return bad("--standby and --primary exclude each other");
  if (robot && (!scenario.empty() || !case_name.empty() || !host.empty())) {
    return bad("--scenario, --case and --host place a module, not a robot");
  }
  if (!robot && (a.standby || a.primary)) return bad("--standby and --primary apply to a robot, not a module");
  if (robot) {
    // <module>/<robot>, with @<strength> for a standby (unplug only).
    const auto slash = name.find('/');
    if (slash == std::string::npos || slash == 0 || slash + 1 == name.size() || (plug && name.find('@') != std::string::npos)) {
      return bad("a robot is named <module>/<arm>" + std::string(plug ? "" : "[@<strength>]") + ", e.g. m1/left; got '" + name + "'");
    }
  } else {
    if (name.empty() || name.find('/') != std::string::npos) return bad("a module name has no '/'; got '" + name + "'");
    if (!scenario.empty() || !case_name.empty()) {
      if (scenario.empty() || case_name.empty()) return bad("give both --scenario FILE and --case NAME");
      // The launcher may run elsewhere: send an absolute path, and check the file here first.
      char resolved[4096];
      if (::realpath(scenario.c_str(), resolved) == nullptr) return bad("cannot open the scenario '" + scenario + "'");
      scenario = resolved;
    }
    if (!host.empty()) {
      if (scenario.empty()) return bad("--host places a new module: give --scenario and --case too");
    }
  }
  msg::ControlRequest req;
  req.command(plug ? msg::CMD_PLUG : msg::CMD_UNPLUG);
  req.target_kind(!robot ? msg::TARGET_MODULE : plug ? msg::TARGET_ROBOT : msg::TARGET_PROCESS);
  req.target(name);
  req.standby(standby);
  req.scenario(scenario);
  req.case_name(case_name);
  req.host(host);
  return send_request(verb, d, req);
}
}  // namespace

int plug_command(const std::vector<std::string>& args) { return plug_or_unplug("plug", args); }
int unplug_command(const std::vector<std::string>& args) { return plug_or_unplug("unplug", args); }

}  // namespace tandem::cli
