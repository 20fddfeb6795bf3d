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
#include "tandem/launcher/spawn.hpp"
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

void agent_usage(std::FILE* f) {
  std::fputs(
      "usage: tandem agent <deploy.yaml> --host NAME [--once]\n"
      "\n"
      "Runs the agent of host NAME of a multi-host deployment (its 'hosts:'): start it on each host before\n"
      "'tandem up'. The launcher asks it over DDS to start the processes placed on NAME (world, supervisor,\n"
      "robots, coordinator) and to signal them; it reports them every 100 ms. Every host needs the same\n"
      "deployment file, scenarios and build at the same paths.\n"
      "\n"
      "  --host NAME   this host's name in 'hosts:'; its address must be one of this machine's\n"
      "  --once        exit when the launcher's run is over, or its launcher has been silent for host_timeout\n"
      "                (default: keep serving: the same launcher once heard again, or the next run)\n"
      "\n"
      "Fencing: when the launcher is silent for host_timeout seconds (a cut link), or says it counts this host\n"
      "as lost (it does not hear the agent), the agent SIGKILLs its processes: standbys on other hosts have\n"
      "taken over. One agent per host: a second one for the same host is refused (exit 2).\n"
      "SIGINT/SIGTERM stop the agent: its processes get SIGTERM, SIGKILL after 5 s, and are reaped.\n"
      "\n"
      "Exit: 0 stopped; 2 bad arguments, an unknown host, or an address not on this machine.\n",
      f);
}

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

struct AgentChildRun {
  unsigned long long spawn_id = 0;
  std::string label;
  pid_t pid = -1;
  bool running = false;
  int status = -1;
  Clock::time_point term_at{};
};

class Agent {
 public:
  Agent(runtime::Deployment d, std::string host, std::string address)
      : d_(std::move(d)), host_(std::move(host)), address_(std::move(address)), dir_(launcher::self_dir()) {}

  void on_request(const msg::AgentRequest& r) {
    if (r.host() != host_ || r.deployment() != d_.name) return;
    if (r.run() == 0) return;
    if (r.run() != run_) {
      if (r.kind() == msg::AGENT_END) return;  // the end of a run this agent does not serve
      // First come, first served: another launcher of this deployment while the one served lives is refused.
      if (run_ != 0 && !run_over_ && silent() <= d_.host_timeout) {
        if (refused_runs_.insert(r.run()).second) {
          note("refused requests of another launcher run (" + std::to_string(r.run()) + ") while serving run " +
               std::to_string(run_) + ": is a second `tandem up` of this deployment running?");
        }
        return;
      }
      new_run(r.run());
    }
    launcher_heard_ = Clock::now();
    if (r.kind() == msg::AGENT_HEARTBEAT) {
      if (r.host_lost()) {
        // One-way partition: this agent hears the launcher, but the launcher does not hear it.
        fence("the launcher counts this host as lost (it does not hear this agent)");
      } else {
        heard_again();
      }
    } else if (r.kind() == msg::AGENT_START) {
      start(r);
    } else if (r.kind() == msg::AGENT_SIGNAL) {
      signal(r);
    } else if (r.kind() == msg::AGENT_END) {
      if (!run_over_) {
        run_over_ = true;
        if (running() > 0) {
          std::printf("tandem agent %s: the launcher's run is over; stopping %d leftover process(es)\n", host_.c_str(), running());
          stop_all(SIGTERM);
        }
      }
    } else {
      note("refused a request of unknown kind " + std::to_string(static_cast<int>(r.kind())) + " (accepted: start, signal, heartbeat, end)");
    }
  }

  /// Seconds since the served launcher was last heard.
  double silent() const { return std::chrono::duration<double>(Clock::now() - launcher_heard_).count(); }

  /// Reaps children, enforces SIGKILL 5 s after SIGTERM, and fences when the launcher is silent.
  void poll() {
    for (auto& c : children_) {
      if (!c.running) continue;
      int st = 0;
      if (::waitpid(c.pid, &st, WNOHANG) == c.pid) {
        c.running = false;
        c.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
        std::printf("tandem agent %s: %s (pid %d) exited with code %d\n", host_.c_str(), c.label.c_str(), c.pid, c.status);
        if (c.status >= 128) killed_ = true;
      } else if (c.term_at != Clock::time_point{} && Clock::now() - c.term_at > std::chrono::seconds(5)) {
        std::printf("tandem agent %s: %s did not stop within 5 s of SIGTERM; SIGKILL\n", host_.c_str(), c.label.c_str());
        ::kill(c.pid, SIGKILL);
        c.term_at = Clock::time_point{};
      }
    }
    if (!run_over_ && silent() > d_.host_timeout) {
      char why[96];
      std::snprintf(why, sizeof why, "the launcher has been silent for %.1f s", silent());
      fence(why);
    }
    std::fflush(stdout);
  }

  void publish(bus::Writer<msg::AgentState, msg::AgentStatePubSubType>& out) {
    msg::AgentState st;
    st.host(host_);
    st.deployment(d_.name);
    st.address(address_);
    st.pid(::getpid());
    st.started(started_);
    st.run(run_);
    for (const auto& c : children_) {
      msg::AgentChild ac;
      ac.spawn_id(c.spawn_id);
      ac.label(c.label);
      ac.pid(c.pid);
      ac.running(c.running);
      ac.status(c.status);
      st.children().push_back(ac);
    }
    st.detail(detail_);
    out.write(st);
  }

  void stop_all(int sig) {
    for (auto& c : children_) {
      if (!c.running) continue;
      ::kill(c.pid, sig);
      if (sig == SIGTERM && c.term_at == Clock::time_point{}) c.term_at = Clock::now();
      if (sig == SIGKILL) killed_ = true;
    }
  }

  int running() const {
    int n = 0;
    for (const auto& c : children_) n += c.running ? 1 : 0;
    return n;
  }
  bool run_over() const { return run_over_; }
  /// It killed its processes because the launcher fell silent (it serves it again when heard again).
  bool fenced() const { return fenced_; }
  bool served() const { return run_ != 0; }
  /// Another agent's state for the same host: the one that started later leaves (true: this one).
  bool yields_to(const msg::AgentState& other) const {
    if (other.host() != host_ || other.deployment() != d_.name || other.pid() == ::getpid()) return false;
    return other.started() < started_ || (other.started() == started_ && other.pid() < ::getpid());
  }
  /// A child was killed by a signal: its shared-memory files may be left (removed by the caller).
  bool take_killed() {
    const bool k = killed_;
    killed_ = false;
    return k;
  }

 private:
  void new_run(unsigned long long run) {
    if (running() > 0) {
      std::printf("tandem agent %s: a new launcher run (%llu); stopping the %d process(es) of the previous one\n",
                  host_.c_str(), run, running());
      stop_all(SIGKILL);
    }
    std::printf("tandem agent %s: serving launcher run %llu\n", host_.c_str(), run);
    run_ = run;
    run_over_ = false;
    fenced_ = false;
    // The previous run's children are forgotten (their spawn ids are the old run's); running ones until reaped.
    std::vector<AgentChildRun> keep;
    for (auto& c : children_) {
      if (c.running) {
        c.spawn_id = 0;
        keep.push_back(c);
      }
    }
    children_ = keep;
    tombstones_.clear();
    seen_.clear();
  }

  /// Fencing: this host counts as lost (standbys elsewhere serve its slots), so what it runs is killed, so that
  /// no primary comes back beside its replacement.
  void fence(const std::string& why) {
    if (fenced_ || running() == 0) return;
    std::printf("tandem agent %s: %s: this host counts as lost, standbys elsewhere serve its slots; SIGKILL to its "
                "%d process(es) (fencing)\n", host_.c_str(), why.c_str(), running());
    stop_all(SIGKILL);
    fenced_ = true;
  }

  void start(const msg::AgentRequest& r) {
    if (!seen_.insert(r.spawn_id()).second) return;  // re-sent: done already
    AgentChildRun c;
    c.spawn_id = r.spawn_id();
    c.label = r.label();
    const auto tomb = tombstones_.find(r.spawn_id());
    if (tomb != tombstones_.end()) {  // signalled before it was started: it never runs
      c.status = 128 + tomb->second;
      children_.push_back(c);
      return;
    }
    static const std::set<std::string> kRoles{"world", "supervisor", "robot", "coordinator"};
    if (kRoles.count(r.role()) == 0) {
      note("refused to start '" + r.label() + "': unknown role '" + r.role() + "' (accepted: world, supervisor, robot, coordinator)");
      c.status = 127;
      children_.push_back(c);
      return;
    }
    if (run_over_) {
      note("refused to start '" + r.label() + "': the launcher's run is over");
      c.status = 127;
      children_.push_back(c);
      return;
    }
    const std::string exe = dir_ + "/tandem-" + r.role();
    std::vector<std::string> args(r.args().begin(), r.args().end());
    launcher::SpawnOptions opt;
    opt.rt_priority = rt_permitted_ ? r.rt_priority() : 0;
    opt.participant_id = r.participant_id();
    opt.identity = r.identity();
    c.pid = launcher::spawn("tandem agent", exe, args, opt);
    c.running = c.pid > 0;
    c.status = c.running ? -1 : 127;
    if (!c.running) note("could not start '" + r.label() + "' (" + exe + ")");
    std::printf("tandem agent %s: started %-22s pid %d\n", host_.c_str(), c.label.c_str(), c.pid);
    children_.push_back(c);
  }

  void signal(const msg::AgentRequest& r) {
    const int sig = r.signal();
    if (sig != SIGTERM && sig != SIGKILL && sig != SIGINT) {
      note("refused signal " + std::to_string(sig) + " for '" + r.label() + "' (accepted: 2, 9, 15)");
      return;
    }
    for (auto& c : children_) {
      if (c.spawn_id != r.spawn_id()) continue;
      if (c.running) {
        ::kill(c.pid, sig);
        if (sig == SIGTERM && c.term_at == Clock::time_point{}) c.term_at = Clock::now();
      }
      return;
    }
    tombstones_[r.spawn_id()] = sig;
  }

  /// The launcher is heard again after this host fenced itself (a healed partition): it may place processes here
  /// again (it counted the fenced ones as failed).
  void heard_again() {
    if (!fenced_) return;
    fenced_ = false;
    std::printf("tandem agent %s: the launcher is heard again; serving it again\n", host_.c_str());
  }

  void note(const std::string& text) {
    detail_ = text;
    std::printf("tandem agent %s: %s\n", host_.c_str(), text.c_str());
  }

 public:
  bool rt_permitted_ = false;

 private:
  runtime::Deployment d_;
  std::string host_, address_, dir_, detail_;
  std::vector<AgentChildRun> children_;
  std::set<unsigned long long> seen_;
  std::map<unsigned long long, int> tombstones_;
  unsigned long long run_ = 0;  ///< the launcher run served (AgentRequest.run), 0: none yet
  double started_ = static_cast<double>(std::time(nullptr));
  std::set<unsigned long long> refused_runs_;
  Clock::time_point launcher_heard_ = Clock::now();
  bool run_over_ = false;  ///< the launcher's run is over (it said so)
  bool fenced_ = false;    ///< the launcher fell silent and this agent killed its processes
  bool killed_ = false;
};

}  // namespace

int agent_command(const std::vector<std::string>& args) {
  std::string file, host;
  bool once = false;
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--help" || args[i] == "-h") {
      agent_usage(stdout);
      return 0;
    } else if (args[i] == "--host" && i + 1 < args.size()) {
      host = args[++i];
    } else if (args[i] == "--once") {
      once = true;
    } else if (!args[i].empty() && args[i][0] == '-') {
      std::fprintf(stderr, "tandem agent: unknown option '%s' (see 'tandem help agent')\n", args[i].c_str());
      return 2;
    } else if (file.empty()) {
      file = args[i];
    } else {
      std::fprintf(stderr, "tandem agent: one deployment file expected, got '%s' too\n", args[i].c_str());
      return 2;
    }
  }
  if (file.empty() || host.empty()) {
    std::fprintf(stderr, "tandem agent: %s\n\n", file.empty() ? "missing the deployment file" : "missing --host NAME");
    agent_usage(stderr);
    return 2;
  }
  runtime::Deployment d;
  try {
    d = runtime::load_deployment(file);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem agent: %s\n", e.what());
    return 2;
  }
  const runtime::HostSpec* spec = runtime::find_host(d, host);
  if (spec == nullptr) {
    std::string list;
    for (const auto& h : d.hosts) list += (list.empty() ? "" : ", ") + h.name;
    std::fprintf(stderr, "tandem agent: %s has no host '%s' (hosts: %s)\n", file.c_str(), host.c_str(),
                 list.empty() ? "none: it is a single-host deployment, run 'tandem up' alone" : list.c_str());
    return 2;
  }
  const auto addrs = local_addresses();
  bool here = false;
  std::string mine;
  for (const auto& a : addrs) {
    here = here || a == spec->address;
    mine += (mine.empty() ? "" : ", ") + a;
  }
  if (!here) {
    std::fprintf(stderr, "tandem agent: host %s's address %s is not on this machine (its addresses: %s)\n",
                 host.c_str(), spec->address.c_str(), mine.c_str());
    return 2;
  }
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
  Agent agent(d, host, spec->address);
  {
    std::string why;
    agent.rt_permitted_ = launcher::fifo_permitted(std::max(1, d.realtime_priority), why);
    if (!agent.rt_permitted_ && d.timing == "realtime" && d.realtime_priority > 0) {
      std::printf("tandem agent %s: note: SCHED_FIFO is not permitted here (%s); processes run with normal "
                  "scheduling\n", host.c_str(), why.c_str());
    }
  }
  const std::time_t started = std::time(nullptr) - 1;
  std::unique_ptr<bus::Participant> part;
  try {
    part = std::make_unique<bus::Participant>(d.domain_id, "agent/" + host, runtime::transport_of(d));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem agent: %s\n", e.what());
    return 2;
  }
  bus::Reader<msg::AgentRequest, msg::AgentRequestPubSubType> requests(*part, bus::kAgentRequestTopic, bus::TopicKind::Control);
  bus::Writer<msg::AgentState, msg::AgentStatePubSubType> state(*part, bus::kAgentStateTopic, bus::TopicKind::Status);
  // One agent per host: another one for this host would start every process a second time. Of two, the one that
  // started later leaves (exit 2), at start-up or whenever they find each other.
  bus::Reader<msg::AgentState, msg::AgentStatePubSubType> others(*part, bus::kAgentStateTopic, bus::TopicKind::Status);
  auto another_agent = [&]() -> bool {
    msg::AgentState st;
    while (others.take(st)) {
      if (agent.yields_to(st)) {
        std::fprintf(stderr, "tandem agent: another agent (pid %lld, address %s) serves host %s of %s already; one "
                             "agent per host: this one leaves\n", static_cast<long long>(st.pid()), st.address().c_str(),
                     host.c_str(), d.name.c_str());
        return true;
      }
    }
    return false;
  };
  // Its own status, as every process's: `tandem status` lists the agents beside what they run.
  runtime::StatusPublisher own(*part, "agent/" + host, "agent", "");
  own.msg().deployment(d.name);
  own.set(runtime::Lifecycle::Active, "");
  std::printf("tandem agent %s: %s, address %s, domain %d, discovery %s; waiting for the launcher\n", host.c_str(),
              d.name.c_str(), spec->address.c_str(), d.domain_id,
              runtime::discovery_text(d).c_str());
  std::fflush(stdout);
  auto published = Clock::now() - std::chrono::seconds(1);
  while (!g_agent_stop) {
    msg::AgentRequest r;
    while (requests.take(r)) agent.on_request(r);
    if (another_agent()) {
      agent.stop_all(SIGKILL);
      agent.poll();
      return 2;
    }
    agent.poll();
    if (agent.take_killed()) runtime::clean_stale_shm(started, static_cast<int>(d.domain_id));
    if (Clock::now() - published >= std::chrono::milliseconds(100)) {
      agent.publish(state);
      own.msg().detail("runs " + std::to_string(agent.running()) + " process(es)");
      own.publish();
      published = Clock::now();
    }
    // --once: the run is over, or its launcher is gone (silent: this host was cut off, or it died).
    if (once && agent.served() && agent.running() == 0 && (agent.run_over() || agent.silent() > d.host_timeout)) {
      std::printf("tandem agent %s: the run is over; exiting (--once)\n", host.c_str());
      agent.publish(state);
      own.set(runtime::Lifecycle::Finalized, "run over");
      return 0;
    }
    requests.wait(0.02);
  }
  std::printf("tandem agent %s: stopping; %d process(es) left\n", host.c_str(), agent.running());
  agent.stop_all(SIGTERM);
  const auto asked = Clock::now();
  while (agent.running() > 0) {
    agent.poll();  // SIGKILL 5 s after SIGTERM
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (Clock::now() - asked > std::chrono::seconds(7)) agent.stop_all(SIGKILL);
  }
  agent.publish(state);
  own.set(runtime::Lifecycle::Finalized, "stopped");
  std::printf("tandem agent %s: stopped\n", host.c_str());
  return 0;
}

}  // namespace tandem::cli
