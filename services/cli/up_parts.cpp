// The parts of `tandem up` that are not its run: see up_parts.hpp.
#include "up_parts.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <random>
#include <set>
#include <thread>
#include <utility>

#include "tandem/sim/module_setup.hpp"
#include "tandem/sim/scenario_yaml.hpp"

namespace tandem::cli::up {

launcher::LoadSpec load_of(const Deployment& d) {
  launcher::LoadSpec l;
  l.realtime = d.timing == "realtime";
  l.overload_brake = d.overload_brake;
  l.simple_discovery = d.discovery == "simple";
  l.pinned = d.cpu_affinity == "module" && d.hosts.empty();
  for (const auto& m : d.modules) l.standbys.push_back(m.standby);
  if (!d.modules.empty()) {
    const runtime::ModuleDeployment first = d.modules.front();
    l.first_module = [first]() -> std::optional<sim::ModuleSetup> {
      const sim::Scenario sc = sim::load_scenario(first.scenario);
      for (const auto& c : sc.cases) {
        if (c.name == first.case_name) return sim::make_module(sc, c);
      }
      return std::nullopt;
    };
  }
  return l;
}

launcher::SupervisorConfig supervisor_config(const Deployment& d, const std::string& file, unsigned long long run) {
  launcher::SupervisorConfig cfg;
  cfg.deployment = d.name;
  cfg.deployment_file = file;
  cfg.coordinated = d.coordinator;
  cfg.coordinator_standby = d.coordinator_standby;
  cfg.coordinator_restart = launcher::RestartRule{d.coordinator_restart, d.coordinator_restart_limit,
                                                  d.coordinator_restart_window, 0.2};
  cfg.timeout = d.timeout;
  cfg.start_timeout = d.start_timeout;
  cfg.realtime = d.timing == "realtime";
  cfg.start_one_by_one = d.module_start == "one_by_one";
  for (const auto& h : d.hosts) cfg.hosts.push_back(h.name);
  cfg.host_timeout = d.host_timeout;
  cfg.run = run;
  // Participant ids for children, the one left longest ago first: 20-119 (0-19 stay for Fast DDS's own choice:
  // the launcher, `tandem status` and other tools).
  cfg.end_participant_id = static_cast<int>(bus::kMaxParticipantId);
  return cfg;
}

size_t done_in(const msg::CoordinatorState& cs) {
  return static_cast<size_t>(std::count_if(cs.done_by().begin(), cs.done_by().end(), [](uint8_t b) { return b != 0; }));
}

pid_t spawn(const std::string& exe, const std::vector<std::string>& args, int rt_priority, int participant_id,
            const std::string& identity, bool own_group, const std::string& discovery, int cpu) {
  return launcher::spawn("tandem up", exe, args,
                         launcher::SpawnOptions{rt_priority, participant_id, identity, own_group, discovery, cpu});
}

launcher::ModuleSpec module_spec(const runtime::ModuleDeployment& cfg, bool* case_found) {
  launcher::ModuleSpec s;
  s.name = cfg.name;
  s.scenario = cfg.scenario;
  s.case_name = cfg.case_name;
  s.standby = cfg.standby;
  s.supervisor_standby = cfg.supervisor_standby;
  s.restart = launcher::RestartRule{cfg.restart, cfg.restart_limit, cfg.restart_window, cfg.restart_backoff};
  s.restart_as_standby = cfg.restart_as == "standby";
  const sim::Scenario sc = sim::load_scenario(cfg.scenario);
  bool found = false;
  for (const auto& c : sc.cases) {
    if (c.name == cfg.case_name) {
      s.h_sg = sim::make_module(sc, c).safe_grasp_force;
      found = true;
    }
  }
  for (const auto& r : sc.robots) s.robots.push_back(r.name);
  if (case_found != nullptr) *case_found = found;
  return s;
}

launcher::Request request_of(const msg::ControlRequest& r) {
  launcher::Request q;
  using C = launcher::Request::Command;
  using T = launcher::Request::Target;
  q.command = r.command() == msg::CMD_DOWN     ? C::Down
              : r.command() == msg::CMD_KILL   ? C::Kill
              : r.command() == msg::CMD_PLUG   ? C::Plug
              : r.command() == msg::CMD_UNPLUG ? C::Unplug
                                               : C::Other;
  q.raw_command = static_cast<int>(r.command());
  q.command_name = runtime::command_name(r.command());
  q.target_kind = r.target_kind() == msg::TARGET_MODULE    ? T::Module
                  : r.target_kind() == msg::TARGET_ROBOT   ? T::Robot
                  : r.target_kind() == msg::TARGET_PROCESS ? T::Process
                                                           : T::Other;
  q.target = r.target();
  q.seq = r.seq();
  q.standby = r.standby();
  q.scenario = r.scenario();
  q.case_name = r.case_name();
  q.host = r.host();
  return q;
}

launcher::AgentReport report_of(const msg::AgentState& st) {
  launcher::AgentReport a;
  a.host = st.host();
  a.pid = st.pid();
  a.run = st.run();
  a.detail = st.detail();
  for (const auto& ac : st.children()) {
    a.children.push_back({ac.spawn_id(), ac.label(), ac.pid(), ac.running(), static_cast<int>(ac.status())});
  }
  return a;
}

void reap_local(launcher::Supervisor& s, bool block) {
  std::vector<int> pids;
  for (const auto& c : s.children()) {
    if (c.running && c.host.empty() && c.pid > 0) pids.push_back(c.pid);
  }
  for (const int pid : pids) {
    int st = 0;
    if (::waitpid(pid, &st, block ? 0 : WNOHANG) == pid) s.on_exit(pid, WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st));
  }
}

unsigned long long new_run() {
  std::random_device rd;
  unsigned long long r = 0;
  while (r == 0) r = (static_cast<unsigned long long>(rd()) << 32) ^ rd();
  return r;
}

namespace {

/// The Discovery Server's own participant: a server over UDP only. With Fast DDS's built-in transports it also
/// listens on shared memory, and its clients on this machine reach it there; a client SIGKILLed while it held the
/// server's port lock (the soak kills about a thousand processes an hour) left the server deaf to every client
/// that came after: soak run 18 (soak-small, seed 12) heard no process started after 151 s, a coordinator's
/// kill, and the deployment wore away as its processes were restarted and never heard (docs/failure-model.md,
/// "Shared memory and SIGKILL"). Over UDP a dead client leaves nothing held. The clients keep their transports.
constexpr const char* kDiscoveryServerProfile = R"(<?xml version="1.0" encoding="UTF-8" ?>
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <profiles>
    <transport_descriptors>
      <transport_descriptor>
        <transport_id>tandem_udp</transport_id>
        <type>UDPv4</type>
      </transport_descriptor>
    </transport_descriptors>
    <participant profile_name="tandem_discovery_server" is_default_profile="true">
      <rtps>
        <userTransports><transport_id>tandem_udp</transport_id></userTransports>
        <useBuiltinTransports>false</useBuiltinTransports>
        <builtin><discovery_config><discoveryProtocol>SERVER</discoveryProtocol></discovery_config></builtin>
      </rtps>
    </participant>
  </profiles>
</dds>
)";

/// Writes kDiscoveryServerProfile to a new file in /tmp; its path, "" if it could not.
std::string write_discovery_profile() {
  char path[] = "/tmp/tandem-discovery-XXXXXX.xml";
  const int fd = ::mkstemps(path, 4);
  if (fd < 0) return "";
  const std::string text = kDiscoveryServerProfile;
  const bool ok = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
  ::close(fd);
  if (!ok) {
    ::unlink(path);
    return "";
  }
  return path;
}

}  // namespace

bool start_discovery(const Deployment& d, std::vector<pid_t>& pids, std::string& profile) {
  if (d.discovery == "server" && d.discovery_start == "external") {
    std::printf("  discovery server             %s (external)\n", runtime::discovery_text(d).c_str());
    runtime::use_discovery(d);
  } else if (d.discovery == "server") {
    const std::string exe = "/usr/bin/fast-discovery-server";
    if (::access(exe.c_str(), X_OK) != 0) {
      std::fprintf(stderr, "tandem up: discovery: server needs %s (Debian package fastdds-tools)\n", exe.c_str());
      return false;
    }
    profile = write_discovery_profile();
    if (profile.empty()) {
      std::fprintf(stderr, "tandem up: note: cannot write the Discovery Server's UDP-only profile in /tmp (%s); it runs "
                           "with Fast DDS's default transports\n", std::strerror(errno));
    }
    // One server per module (discovery_servers: module): each relays its own module's churn to its own processes.
    // A Fast DDS 2.9.1 server takes every entry of an inherited ROS_DISCOVERY_SERVER as a remote server to link
    // with: started from a shell that has it, the modules' servers would relay to each other (or to a stranger).
    ::unsetenv("ROS_DISCOVERY_SERVER");
    const auto servers = runtime::discovery_servers(d);
    for (const runtime::DiscoveryServer& s : servers) {
      std::vector<std::string> args{"-i", std::to_string(s.id), "-l", s.address, "-p", std::to_string(s.port)};
      if (!profile.empty()) args.insert(args.end(), {"-x", profile});
      const pid_t pid = spawn(exe, args);
      if (pid < 0) return false;
      pids.push_back(pid);
      std::printf("  started discovery server     pid %d on %s:%d%s\n", pid, s.address.c_str(), s.port,
                  s.module.empty() ? "" : (" (" + s.module + ")").c_str());
    }
    runtime::use_discovery(d);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // listening before the first client comes
    for (size_t i = 0; i < pids.size(); ++i) {
      if (::waitpid(pids[i], nullptr, WNOHANG) != pids[i]) continue;
      std::fprintf(stderr, "tandem up: the Discovery Server exited at start: is %s an address of this machine, and "
                           "port %d free? (discovery_start: external uses one that runs already)\n",
                   servers[i].address.c_str(), servers[i].port);
      return false;
    }
  }
  return true;
}



namespace {

/// A robot's row of the summary (and its keys in the summary file); false if its grasp went below h_sg.
bool summarize_robot(const std::string& id, const msg::RobotSummary& r, double h_sg, std::ofstream& out) {
  char min_force[32] = "-";  // a robot that computed no tick has no force to report
  if (r.ticks() > 0) std::snprintf(min_force, sizeof min_force, "%.2f", r.min_normal_force());
  std::printf("%-16s %8llu %12.4e %12.4e %12.4e %10.4f %10s %9llu\n", id.c_str(),
              static_cast<unsigned long long>(r.ticks()), r.ep_sel_rms(), r.ep_pos_rms(), r.ep_ori_rms(), r.eh_rms(),
              min_force, static_cast<unsigned long long>(r.rejected()));
  if (out) {
    out << id << ".ep_pos_rms=" << r.ep_pos_rms() << "\n" << id << ".ep_ori_rms=" << r.ep_ori_rms() << "\n"
        << id << ".ep_sel_rms=" << r.ep_sel_rms() << "\n" << id << ".eh_rms=" << r.eh_rms() << "\n"
        << id << ".min_normal_force=" << r.min_normal_force() << "\n" << id << ".ticks=" << r.ticks() << "\n"
        << id << ".rejected=" << r.rejected() << "\n";
  }
  return !(r.ticks() > 0 && r.min_normal_force() < h_sg);
}

/// A world's lines of the summary (and its keys in the summary file); false if its object slipped or was let go.
bool summarize_world(const std::string& name, const msg::WorldSummary& ws, double h_sg, std::ofstream& out) {
  std::printf("%s: %llu ticks, object at (%.6f, %.6f), slips %llu, contact lost %llu, rejected commands %llu, "
              "%s %llu, braked arm-ticks %llu\n",
              name.c_str(), static_cast<unsigned long long>(ws.ticks()), ws.object_final()[0], ws.object_final()[1],
              static_cast<unsigned long long>(ws.slip_events()), static_cast<unsigned long long>(ws.contact_lost()),
              static_cast<unsigned long long>(ws.rejected_commands()), ws.realtime() ? "late arm-ticks" : "brakings",
              static_cast<unsigned long long>(ws.late_commands()), static_cast<unsigned long long>(ws.braked_ticks()));
  for (size_t i = 0; i < ws.switch_gap_ms().size(); ++i) {
    std::printf("%s: %s after %.1f ms; over the next 300 ticks worst |e_p| %.3e m, lowest normal force %.2f N "
                "(h_sg %.2f N)\n",
                name.c_str(), ws.switch_failover()[i] ? "failover" : "takeover", ws.switch_gap_ms()[i],
                ws.switch_ep_max()[i], ws.switch_hn_min()[i], h_sg);
  }
  if (ws.realtime()) {
    std::printf("%s: real time: sample->command latency p50 %.0f us, p99 %.0f us, max %.0f us; late arm-ticks %llu "
                "of %llu (%.2f%%); world tick start late p99 %.0f us, world overruns %llu; paused for load %llu "
                "time(s), %.1f s\n",
                name.c_str(), ws.latency_p50_us(), ws.latency_p99_us(), ws.latency_max_us(),
                static_cast<unsigned long long>(ws.late_commands()), 2ULL * ws.ticks(),
                ws.ticks() > 0 ? 50.0 * static_cast<double>(ws.late_commands()) / static_cast<double>(ws.ticks()) : 0.0,
                ws.wake_late_p99_us(), static_cast<unsigned long long>(ws.overruns()),
                static_cast<unsigned long long>(ws.load_pauses()), static_cast<double>(ws.load_paused_ticks()) * 1e-3);
  }
  if (out) {
    out << name << ".ticks=" << ws.ticks() << "\n" << name << ".slip_events=" << ws.slip_events() << "\n"
        << name << ".contact_lost=" << ws.contact_lost() << "\n" << name
        << ".rejected_commands=" << ws.rejected_commands() << "\n" << name
        << ".late_commands=" << ws.late_commands() << "\n" << name << ".latency_p50_us=" << ws.latency_p50_us()
        << "\n" << name << ".latency_p99_us=" << ws.latency_p99_us() << "\n" << name
        << ".failovers=" << ws.failovers() << "\n" << name << ".failover_max_ms=" << ws.failover_max_ms() << "\n"
        << name << ".braked_ticks=" << ws.braked_ticks() << "\n" << name << ".overruns=" << ws.overruns() << "\n"
        << name << ".load_pauses=" << ws.load_pauses() << "\n" << name << ".load_paused_ticks=" << ws.load_paused_ticks()
        << "\n";
    auto list = [&out, &module = name](const char* key, const auto& seq) {  // (C++17: no binding captures)
      out << module << "." << key << "=";
      for (size_t i = 0; i < seq.size(); ++i) out << (i ? "," : "") << static_cast<double>(seq[i]);
      out << "\n";
    };
    list("switch_gap_ms", ws.switch_gap_ms());
    list("switch_failover", ws.switch_failover());
    list("switch_ep_max", ws.switch_ep_max());
    list("switch_hn_min", ws.switch_hn_min());
    for (size_t i = 0; i < ws.q_final().size(); ++i) out << name << ".q_final" << i << "=" << ws.q_final()[i] << "\n";
    for (size_t i = 0; i < 3; ++i) out << name << ".object_final" << i << "=" << ws.object_final()[i] << "\n";
  }
  return ws.slip_events() == 0 && ws.contact_lost() == 0;
}

/// The deployment's lines after the modules': processes that failed, the coordinator's count, start-up costs and
/// the launcher's repairs, restarts and parks.
void summarize_run(const launcher::Supervisor& L, const Deployment& d, Heard& heard, std::ofstream& out) {
  for (const auto& c : L.children()) {
    if (c.status != 0) {
      std::printf("process %s exited with code %d%s\n", c.label.c_str(), c.status,
                  c.expected ? " (unplugged, or its module stopped)" : "");
    }
  }
  if (d.coordinator && heard.have_coord) {
    const size_t done = done_in(heard.last_coord);
    const size_t dup = heard.last_coord.done_total() > done ? static_cast<size_t>(heard.last_coord.done_total() - done) : 0;
    std::printf("coordinator: %zu/%zu tasks done, %zu duplicate(s)\n", done, d.tasks.size(), dup);
    if (out) out << "coordinator.tasks_done=" << done << "\ncoordinator.duplicates=" << dup << "\n";
    for (size_t t = 0; t < heard.last_coord.done_by().size() && t < d.tasks.size() && out; ++t) {
      const uint8_t by = heard.last_coord.done_by()[t];
      if (by != 0 && by <= heard.last_coord.modules().size()) {
        out << "coordinator.task." << d.tasks[t].name << "=" << heard.last_coord.modules()[by - 1u] << "\n";
      }
    }
  }
  for (auto& [role, v] : heard.start_cpu) {
    if (v.empty()) continue;
    std::sort(v.begin(), v.end());
    const double median = v[v.size() / 2];
    std::printf("start-up CPU of a %s (start to active): median %.3f s, max %.3f s over %zu start(s)\n", role.c_str(),
                median, v.back(), v.size());
    if (out) out << "startup_cpu." << role << ".median_s=" << median << "\nstartup_cpu." << role << ".starts=" << v.size() << "\n";
  }
  std::printf("tandem up: start-up repairs (modules restarted because they did not come up): %llu\n", L.start_repairs());
  if (L.forced_drains() > 0) {
    std::printf("tandem up: unplugged modules stopped before their task ended (drain over %.0f s, or paused for load "
                "%.0f s while draining): %llu\n", launcher::DrainWatch::kTimeout, launcher::DrainWatch::kPausedForLoad,
                L.forced_drains());
  }
  if (out) {
    out << "start_repairs=" << L.start_repairs() << "\nplan_restarts=" << L.plan_restarts() << "\nforced_drains=" << L.forced_drains()
        << "\ndeaf_leaders=" << L.deaf_leaders() << "\n";
  }
  if (L.plan_restarts() > 0) std::printf("tandem up: modules restarted because their supervisors lost the plan: %llu\n", L.plan_restarts());
  if (L.governed()) {
    std::printf("tandem up: modules parked for load during the run: %llu time(s); parked at the end: %s\n",
                L.parks(), L.parked_text().empty() ? "none" : L.parked_text().c_str());
    if (out) out << "shedding.parks=" << L.parks() << "\nshedding.parked=" << L.parked_text() << "\n";
  }
}

}  // namespace

bool print_summary(double wall_s, const launcher::Supervisor& L, const Deployment& d, Heard& heard,
                   const std::string& summary_file, std::ofstream& out, bool& failed) {
  std::printf("\nsummary (%.1f s wall)\n", wall_s);
  std::printf("%-16s %8s %12s %12s %12s %10s %10s %9s\n", "robot", "ticks", "e_p Sp RMS", "e_p pos RMS",
              "e_p phi RMS", "e_h RMS N", "min h_n N", "rejected");
  if (!summary_file.empty()) {
    out.open(summary_file);
    if (!out) std::fprintf(stderr, "tandem up: cannot write the summary to %s\n", summary_file.c_str());
    out.precision(17);
  }
  bool grasp_ok = true;
  for (const auto& [name, mr] : L.modules()) {
    if (!mr.started) continue;
    // Failed or unplugged modules: reported only.
    const bool counted = mr.end.running() || mr.end.is(launcher::ModuleEnd::Kind::Draining);
    if (!mr.end.running()) std::printf("%s: %s\n", name.c_str(), mr.end.text().c_str());
    if (out) out << name << ".end=" << (mr.end.running() ? "ran" : mr.end.word()) << "\n";
    for (const auto& [id, r] : heard.robots) {
      if (id.rfind(name + "/", 0) != 0) continue;
      if (!summarize_robot(id, r, mr.spec.h_sg, out) && counted) grasp_ok = false;
    }
    const auto w = heard.worlds.find(name);
    if (w == heard.worlds.end()) {
      std::printf("%s: no summary from the world\n", name.c_str());
      if (counted) failed = true;
      continue;
    }
    if (!summarize_world(name, w->second, mr.spec.h_sg, out) && counted) grasp_ok = false;
  }
  summarize_run(L, d, heard, out);
  return grasp_ok;
}

}  // namespace tandem::cli::up
