// `tandem agent <deploy.yaml> --host NAME`: the per-host agent of a multi-host deployment (docs/multihost.md).
// It starts and supervises the role processes the launcher places on its host, on the launcher's requests over
// DDS (AgentRequest), and reports them with its heartbeat (AgentState, every 100 ms). It runs only this
// project's role executables (tandem-world, -supervisor, -robot, -coordinator, from its own directory), never a
// path from the wire. It serves one launcher run at a time (AgentRequest.run), and only the launcher may write
// requests. Fencing: when the launcher has been silent for the deployment's host_timeout, or its heartbeat says
// it counts this host as lost, the agent kills what it runs: standbys elsewhere have taken over.
#include "agent_command.hpp"

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/wait.h>
#include <tandemPubSubTypes.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <map>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "tandem/dds/bus.hpp"
#include "tandem/launcher/agent_core.hpp"
#include "tandem/launcher/spawn.hpp"
#include "tandem/runtime/args.hpp"
#include "tandem/runtime/deployment.hpp"
#include "tandem/runtime/security.hpp"
#include "tandem/runtime/shm_clean.hpp"
#include "tandem/runtime/status.hpp"

namespace tandem::cli {
namespace {

namespace bus = tandem::dds;
using Clock = std::chrono::steady_clock;

std::atomic<bool> g_agent_stop{false};
void on_agent_signal(int) { g_agent_stop = true; }


/// The IPv4 addresses of this machine's interfaces.
std::vector<std::string> local_addresses() {
  std::vector<std::string> out;
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return out;
  for (ifaddrs* a = list; a != nullptr; a = a->ifa_next) {
    if (a->ifa_addr == nullptr || a->ifa_addr->sa_family != AF_INET) continue;
    char text[INET_ADDRSTRLEN] = {};
    const auto* in = reinterpret_cast<const sockaddr_in*>(a->ifa_addr);
    if (::inet_ntop(AF_INET, &in->sin_addr, text, sizeof text) != nullptr) out.emplace_back(text);
  }
  ::freeifaddrs(list);
  return out;
}

/// Processes of this machine: fork/exec (launcher::spawn), kill, waitpid.
class OsProcesses : public launcher::Processes {
 public:
  explicit OsProcesses(const runtime::Deployment& d) : d_(d) {}
  int start(const Spec& s) override {
    launcher::SpawnOptions opt;
    // A module's process: a client of its module's Discovery Server only (runtime::discovery_env).
    if (!s.module.empty()) opt.discovery = runtime::discovery_env(d_, s.module);
    opt.rt_priority = s.rt_priority;
    opt.participant_id = s.participant_id;
    opt.identity = s.identity;
    opt.own_group = s.own_group;
    return launcher::spawn("tandem agent", s.exe, s.args, opt);
  }
  void signal(int pid, int sig) override { ::kill(pid, sig); }
  int reap(int pid) override {
    int st = 0;
    if (::waitpid(pid, &st, WNOHANG) != pid) return -1;
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  }

 private:
  const runtime::Deployment& d_;
};

launcher::AgentRequestIn from_wire(const msg::AgentRequest& r) {
  using Kind = launcher::AgentRequestIn::Kind;
  launcher::AgentRequestIn in;
  switch (r.kind()) {
    case msg::AGENT_START: in.kind = Kind::Start; break;
    case msg::AGENT_SIGNAL: in.kind = Kind::Signal; break;
    case msg::AGENT_HEARTBEAT: in.kind = Kind::Heartbeat; break;
    case msg::AGENT_END: in.kind = Kind::End; break;
    default: in.kind = Kind::Unknown; break;
  }
  in.raw_kind = static_cast<int>(r.kind());
  in.run = r.run();
  in.spawn_id = r.spawn_id();
  in.label = r.label();
  in.role = r.role();
  in.args.assign(r.args().begin(), r.args().end());
  in.rt_priority = r.rt_priority();
  in.participant_id = r.participant_id();
  in.signal = r.signal();
  in.identity = r.identity();
  in.host_lost = r.host_lost();
  return in;
}

/// The agent process around launcher::AgentCore: its clock, its state on the wire, and the one-agent-per-host rule.
class Agent {
 public:
  Agent(const runtime::Deployment& d, std::string host, std::string address)
      : d_(d), host_(std::move(host)), address_(std::move(address)), procs_(d),
        core_(procs_, launcher::self_dir(), d.host_timeout, now()) {
    core_.set_log([this](const std::string& line) { std::printf("tandem agent %s: %s\n", host_.c_str(), line.c_str()); });
  }
  launcher::AgentCore& core() { return core_; }
  double now() const { return std::chrono::duration<double>(Clock::now() - t0_).count(); }
  void on_request(const msg::AgentRequest& r) {
    if (r.host() != host_ || r.deployment() != d_.name) return;
    core_.on_request(from_wire(r), now());
  }
  void poll() {
    core_.poll(now());
    std::fflush(stdout);
  }
  void stop_all(int sig) { core_.stop_all(sig, now()); }
  void publish(bus::Writer<msg::AgentState, msg::AgentStatePubSubType>& out) const {
    msg::AgentState st;
    st.host(host_);
    st.deployment(d_.name);
    st.address(address_);
    st.pid(::getpid());
    st.started(started_);
    st.run(core_.run());
    for (const auto& c : core_.children()) {
      msg::AgentChild ac;
      ac.spawn_id(c.spawn_id);
      ac.label(c.label);
      ac.pid(c.pid);
      ac.running(c.running);
      ac.status(c.status);
      st.children().push_back(ac);
    }
    st.detail(core_.detail());
    out.write(st);
  }
  /// Another agent's state for the same host: the one that started later leaves (true: this one).
  bool yields_to(const msg::AgentState& other) const {
    if (other.host() != host_ || other.deployment() != d_.name || other.pid() == ::getpid()) return false;
    return other.started() < started_ || (other.started() == started_ && other.pid() < ::getpid());
  }

 private:
  const runtime::Deployment& d_;
  std::string host_, address_;
  Clock::time_point t0_ = Clock::now();
  double started_ = static_cast<double>(std::time(nullptr));
  OsProcesses procs_;
  launcher::AgentCore core_;
};

struct AgentArgs {
  std::string file, host;
  bool once = false;
};

/// The command line, on CLI11 (runtime::parse_args): `tandem help agent` prints the same text as --help.
void describe(CLI::App& app, AgentArgs& o) {
  app.description(
      "Runs the agent of host NAME of a multi-host deployment (its 'hosts:'): start it on each host before\n"
      "'tandem up'. The launcher asks it over DDS to start the processes placed on NAME (world, supervisor,\n"
      "robots, coordinator) and to signal them; it reports them every 100 ms. Every host needs the same\n"
      "deployment file, scenarios and build at the same paths.");
  app.add_option("deploy", o.file, "the deployment file (docs/multihost.md)")->required()->type_name("DEPLOY.yaml");
  app.add_option("--host", o.host, "this host's name in 'hosts:'; its address must be one of this machine's")
      ->required()->type_name("NAME");
  app.add_flag("--once", o.once,
               "exit when the launcher's run is over, or its launcher has been silent for host_timeout\n"
               "(default: keep serving: the same launcher once heard again, or the next run)");
  app.footer(
      "Fencing: when the launcher is silent for host_timeout seconds (a cut link), or says it counts this host\n"
      "as lost (it does not hear the agent), the agent SIGKILLs its processes: standbys on other hosts have\n"
      "taken over. One agent per host: a second one for the same host is refused (exit 2).\n"
      "SIGINT/SIGTERM stop the agent: its processes get SIGTERM, SIGKILL after 5 s, and are reaped.\n"
      "\n"
      "Exit: 0 stopped; 2 bad arguments, an unknown host, or an address not on this machine.");
}

/// Reads the command line; -1 to go on, else the exit code (0 after --help).
int parse_agent_args(const std::vector<std::string>& args, AgentArgs& o) {
  CLI::App app("", "tandem agent");
  describe(app, o);
  return runtime::parse_args(app, args);
}

/// The host's entry of the deployment, if it is this machine's; else nullptr, said.
const runtime::HostSpec* this_host(const runtime::Deployment& d, const AgentArgs& o) {
  const runtime::HostSpec* spec = runtime::find_host(d, o.host);
  if (spec == nullptr) {
    std::string list;
    for (const auto& h : d.hosts) list += (list.empty() ? "" : ", ") + h.name;
    std::fprintf(stderr, "tandem agent: %s has no host '%s' (hosts: %s)\n", o.file.c_str(), o.host.c_str(),
                 list.empty() ? "none: it is a single-host deployment, run 'tandem up' alone" : list.c_str());
    return nullptr;
  }
  bool here = false;
  std::string mine;
  for (const auto& a : local_addresses()) {
    here = here || a == spec->address;
    mine += (mine.empty() ? "" : ", ") + a;
  }
  if (!here) {
    std::fprintf(stderr, "tandem agent: host %s's address %s is not on this machine (its addresses: %s)\n",
                 o.host.c_str(), spec->address.c_str(), mine.c_str());
    return nullptr;
  }
  return spec;
}

/// Signals, discovery, security and scheduling for the agent of `host`; -1 to go on, else the exit code.
int prepare_agent(const runtime::Deployment& d, const std::string& host) {
  struct sigaction sa {};
  sa.sa_handler = on_agent_signal;
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
  runtime::use_discovery(d);  // for itself and the processes it starts
  ::setenv("TANDEM_HOST", host.c_str(), 1);  // its processes name their host in their status
  // DDS-Security: the agent joins as "agent.<host>"; its children inherit the keys' directory and get their
  // slot's identity with each start request.
  if (!d.security_keys.empty()) {
    const std::string err = runtime::use_security(d, runtime::identity_name("agent", host));
    if (!err.empty()) {
      std::fprintf(stderr, "tandem agent: %s\n", err.c_str());
      return 2;
    }
  }
  return -1;
}

/// Whether SCHED_FIFO is permitted; as the launcher, a real-time deployment's processes start at kServiceNice
/// (inherited from the agent).
bool set_scheduling(const runtime::Deployment& d, const std::string& host) {
  std::string why;
  const bool rt_permitted = launcher::fifo_permitted(std::max(1, d.realtime_priority), why);
  if ((rt_permitted && d.timing == "realtime" && d.realtime_priority > 0) || d.timing == "lockstep") {
    (void)launcher::raise_service_priority(why, d.timing != "lockstep");  // lockstep: its group holds per-tick work
  }
  if (!rt_permitted && d.timing == "realtime" && d.realtime_priority > 0) {
    std::printf("tandem agent %s: note: SCHED_FIFO is not permitted here (%s); processes run with normal "
                "scheduling\n", host.c_str(), why.c_str());
  }
  return rt_permitted;
}

/// The agent's DDS side and loop: requests in, its state and status out, until stopped (or, --once, the run over).
class AgentRun {
 public:
  AgentRun(const runtime::Deployment& d, const AgentArgs& o, const runtime::HostSpec& spec, Agent& agent,
           bus::Participant& part)
      : d_(d), o_(o), spec_(spec), agent_(agent), requests_(part, bus::kAgentRequestTopic, bus::TopicKind::Control),
        state_(part, bus::kAgentStateTopic, bus::TopicKind::Status),
        others_(part, bus::kAgentStateTopic, bus::TopicKind::Status), own_(part, "agent/" + o.host, "agent", "") {
    // Its own status, as every process's: `tandem status` lists the agents beside what they run.
    own_.msg().deployment(d.name);
    own_.set(runtime::Lifecycle::Active, "");
  }

  int run() {
    std::printf("tandem agent %s: %s, address %s, domain %d, discovery %s; waiting for the launcher\n", o_.host.c_str(),
                d_.name.c_str(), spec_.address.c_str(), d_.domain_id, runtime::discovery_text(d_).c_str());
    std::fflush(stdout);
    auto published = Clock::now() - std::chrono::seconds(1);
    while (!g_agent_stop) {
      msg::AgentRequest r;
      while (requests_.take(r)) agent_.on_request(r);
      if (another_agent()) {
        agent_.stop_all(SIGKILL);
        agent_.poll();
        return 2;
      }
      agent_.poll();
      // Killed children's shared-memory files, once no live process has used them for a minute (ShmSweeper).
      const std::time_t wall = std::time(nullptr);
      if (agent_.core().take_killed() || sweeper_.due(wall)) sweeper_.sweep(wall);
      if (Clock::now() - published >= std::chrono::milliseconds(100)) {
        agent_.publish(state_);
        own_.msg().detail("runs " + std::to_string(agent_.core().running()) + " process(es)");
        own_.publish();
        published = Clock::now();
      }
      // --once: the run is over, or its launcher is gone (silent: this host was cut off, or it died).
      const launcher::AgentCore& core = agent_.core();
      if (o_.once && core.served() && core.running() == 0 &&
          (core.run_over() || core.silent(agent_.now()) > d_.host_timeout)) {
        std::printf("tandem agent %s: the run is over; exiting (--once)\n", o_.host.c_str());
        final_clean();
        agent_.publish(state_);
        own_.set(runtime::Lifecycle::Finalized, "run over");
        return 0;
      }
      requests_.wait(0.02);
    }
    return stop();
  }

 private:
  // One agent per host: another one for this host would start every process a second time. Of two, the one that
  // started later leaves (exit 2), at start-up or whenever they find each other.
  bool another_agent() {
    msg::AgentState st;
    while (others_.take(st)) {
      if (agent_.yields_to(st)) {
        std::fprintf(stderr, "tandem agent: another agent (pid %lld, address %s) serves host %s of %s already; one "
                             "agent per host: this one leaves\n", static_cast<long long>(st.pid()), st.address().c_str(),
                     o_.host.c_str(), d_.name.c_str());
        return true;
      }
    }
    return false;
  }

  // Its children are gone: their shared-memory files that no live process uses go now, without the sweeper's minute.
  void final_clean() { runtime::clean_stale_shm(started_, static_cast<int>(d_.domain_id)); }

  int stop() {
    std::printf("tandem agent %s: stopping; %d process(es) left\n", o_.host.c_str(), agent_.core().running());
    agent_.stop_all(SIGTERM);
    const auto asked = Clock::now();
    while (agent_.core().running() > 0) {
      agent_.poll();  // SIGKILL 5 s after SIGTERM
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      if (Clock::now() - asked > std::chrono::seconds(7)) agent_.stop_all(SIGKILL);
    }
    final_clean();
    agent_.publish(state_);
    own_.set(runtime::Lifecycle::Finalized, "stopped");
    std::printf("tandem agent %s: stopped\n", o_.host.c_str());
    return 0;
  }

  const runtime::Deployment& d_;
  const AgentArgs& o_;
  const runtime::HostSpec& spec_;
  Agent& agent_;
  const std::time_t started_ = std::time(nullptr) - 1;
  runtime::ShmSweeper sweeper_{started_, static_cast<int>(d_.domain_id)};
  bus::Reader<msg::AgentRequest, msg::AgentRequestPubSubType> requests_;
  bus::Writer<msg::AgentState, msg::AgentStatePubSubType> state_;
  bus::Reader<msg::AgentState, msg::AgentStatePubSubType> others_;
  runtime::StatusPublisher own_;
};

}  // namespace

int agent_command(const std::vector<std::string>& args) {
  AgentArgs o;
  if (const int code = parse_agent_args(args, o); code >= 0) return code;
  runtime::Deployment d;
  try {
    d = runtime::load_deployment(o.file);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem agent: %s\n", e.what());
    return 2;
  }
  const runtime::HostSpec* spec = this_host(d, o);
  if (spec == nullptr) return 2;
  if (const int code = prepare_agent(d, o.host); code >= 0) return code;
  Agent agent(d, o.host, spec->address);
  agent.core().rt_permitted = set_scheduling(d, o.host);
  std::unique_ptr<bus::Participant> part;
  try {
    // UDP only, as the launcher (up_run.cpp: a killed sender cannot wedge its receiving).
    part = std::make_unique<bus::Participant>(d.domain_id, "agent/" + o.host, bus::Transport::Udp);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem agent: %s\n", e.what());
    return 2;
  }
  AgentRun run(d, o, *spec, agent, *part);
  return run.run();
}

}  // namespace tandem::cli
