// `tandem up`: starts a deployment as separate processes (world, supervisor and two robots per module) that
// talk only over Fast DDS, follows them, and ends with a summary. Ctrl-C / SIGTERM stops every child; no
// child outlives the launcher (PR_SET_PDEATHSIG), and every child is reaped.
#include "up_command.hpp"

#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <tandemPubSubTypes.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "tandem/runtime/deployment.hpp"
#include "live_view.hpp"
#include "tandem/dds/bus.hpp"
#include "tandem/sim/module_setup.hpp"
#include "tandem/sim/scenario_yaml.hpp"

namespace tandem::cli {
using runtime::Deployment;
using runtime::load_deployment;
namespace {

namespace bus = tandem::dds;

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

struct Child {
  std::string label;
  pid_t pid = -1;
  std::string arm;  ///< robots: the arm it controls (a dead robot is not fatal while another serves the arm)
  std::vector<std::string> args;  ///< robots: how to start it again
  const runtime::ModuleDeployment* module = nullptr;
  bool reported = false;
  int status = -1;  ///< exit code once reaped (128 + signal if killed)
  bool running = true;
};

std::string self_dir() {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) return ".";
  buf[n] = '\0';
  std::string p(buf);
  return p.substr(0, p.rfind('/'));
}

pid_t spawn(const std::string& exe, const std::vector<std::string>& args) {
  // Everything the child needs is built before fork: after fork only async-signal-safe calls.
  std::vector<char*> argv;
  argv.push_back(const_cast<char*>(exe.c_str()));
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t launcher = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    std::fprintf(stderr, "tandem up: cannot start %s: fork failed: %s\n", exe.c_str(), std::strerror(errno));
    return -1;
  }
  if (pid != 0) return pid;
  ::signal(SIGINT, SIG_DFL);  // the launcher's handlers must not be inherited
  ::signal(SIGTERM, SIG_DFL);
  ::prctl(PR_SET_PDEATHSIG, SIGTERM);  // never outlive the launcher
  if (::getppid() != launcher) ::_exit(127);
  ::execv(exe.c_str(), argv.data());
  static const char msg[] = "tandem up: cannot exec a role process\n";
  (void)!::write(2, msg, sizeof msg - 1);
  ::_exit(127);
}

void stop_all(std::vector<Child>& children, int sig) {
  for (auto& c : children) {
    if (c.running && c.pid > 0) ::kill(c.pid, sig);
  }
}

void reap(std::vector<Child>& children, bool block) {
  for (auto& c : children) {
    if (c.running && c.pid <= 0) {  // never started
      c.running = false;
      c.status = 127;
    }
    if (!c.running) continue;
    int st = 0;
    const pid_t r = ::waitpid(c.pid, &st, block ? 0 : WNOHANG);
    if (r == c.pid) {
      c.running = false;
      c.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    }
  }
}

int running_count(const std::vector<Child>& children) {
  int n = 0;
  for (const auto& c : children) n += c.running ? 1 : 0;
  return n;
}

}  // namespace

void up_usage(std::FILE* f) {
  std::fputs(
      "usage: tandem up <deploy.yaml> [--summary FILE]\n"
      "\n"
      "Starts every module of the deployment as separate processes over Fast DDS: tandem-world,\n"
      "tandem-supervisor and one tandem-robot per arm, in lockstep or real-time timing. Prints progress\n"
      "while it runs and a summary at the end (RMS per robot, slips, contact losses, rejected samples,\n"
      "and in real time the sample->command latency and late ticks).\n"
      "--summary FILE also writes the summary as key=value lines (full precision).\n"
      "Ctrl-C or SIGTERM stops every process cleanly. Schema: docs/architecture.md.\n"
      "\n"
      "Exit: 0 every process finished and every module kept the safe grasp; 1 a process failed or a\n"
      "grasp was lost; 2 bad arguments or configuration (nothing is started).\n",
      f);
}

int up_command(const std::vector<std::string>& args) {
  std::string file, summary_file;
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--help" || args[i] == "-h") {
      up_usage(stdout);
      return 0;
    } else if (args[i] == "--summary" && i + 1 < args.size()) {
      summary_file = args[++i];
    } else if (!args[i].empty() && args[i][0] == '-') {
      std::fprintf(stderr, "tandem up: unknown option '%s' (see 'tandem help up')\n", args[i].c_str());
      return 2;
    } else if (file.empty()) {
      file = args[i];
    } else {
      std::fprintf(stderr, "tandem up: one deployment file expected, got '%s' too\n", args[i].c_str());
      return 2;
    }
  }
  if (file.empty()) {
    std::fprintf(stderr, "tandem up: missing the deployment file\n\n");
    up_usage(stderr);
    return 2;
  }
  Deployment d;
  std::map<std::string, double> h_sg;                     // per module
  std::map<std::string, std::vector<std::string>> robot_names;  // per module
  try {
    d = load_deployment(file);
    for (const auto& m : d.modules) {
      const sim::Scenario sc = sim::load_scenario(m.scenario);
      for (const auto& c : sc.cases) {
        if (c.name == m.case_name) h_sg[m.name] = sim::make_module(sc, c).safe_grasp_force;
      }
      for (const auto& r : sc.robots) robot_names[m.name].push_back(r.name);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem up: %s\n", e.what());
    return 2;
  }

  struct sigaction sa {};
  sa.sa_handler = on_signal;
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);

  bus::Participant part(d.domain_id, "launcher/" + d.name,
                        runtime::transport_of(d));
  bus::Reader<msg::RobotSummary, msg::RobotSummaryPubSubType> robot_sum(part, bus::kRobotSummaryTopic,
                                                                       bus::TopicKind::Summary);
  bus::Reader<msg::WorldSummary, msg::WorldSummaryPubSubType> world_sum(part, bus::kWorldSummaryTopic,
                                                                       bus::TopicKind::Summary);

  bus::Reader<msg::ProcessStatus, msg::ProcessStatusPubSubType> status(part, bus::kStatusTopic,
                                                                       bus::TopicKind::Status);
  bus::Reader<msg::ControlRequest, msg::ControlRequestPubSubType> control(part, bus::kControlTopic,
                                                                         bus::TopicKind::Control);
  LiveView view(d.name);
  const std::string dir = self_dir();
  std::vector<Child> children;
  std::printf("tandem up %s: %zu module(s), domain %d, %s, %s timing\n", d.name.c_str(), d.modules.size(),
              d.domain_id, d.transport.c_str(), d.timing.c_str());
  for (const auto& m : d.modules) {
    std::vector<std::string> common{"--scenario", m.scenario, "--case",      m.case_name,
                                          "--module",   m.name,     "--domain",    std::to_string(d.domain_id),
                                          "--transport", d.transport, "--timeout", std::to_string(d.timeout),
                                          "--timing",   d.timing,   "--deployment", d.name};
    if (d.coordinator) common.push_back("--continuous");
    children.push_back({m.name + "/world", spawn(dir + "/tandem-world", common), "", {}, &m});
    children.push_back({m.name + "/supervisor", spawn(dir + "/tandem-supervisor", common), "", {}, &m});
    for (const auto& robot : robot_names[m.name]) {
      for (int i = 0; i <= m.standby; ++i) {
        // The primary has strength 100; standbys 50, 40, ...: the world follows the strongest live one.
        const int strength = i == 0 ? 100 : 60 - 10 * i;
        std::vector<std::string> a = common;
        a.insert(a.end(), {"--arm", robot, "--strength", std::to_string(strength)});
        const std::string label = m.name + "/" + robot + (i == 0 ? "" : "@" + std::to_string(strength));
        children.push_back({label, spawn(dir + "/tandem-robot", a), m.name + "/" + robot, a, &m});
      }
    }
  }
  if (d.coordinator) {
    children.push_back({"coordinator", spawn(dir + "/tandem-coordinator",
                                             {"--deployment-file", file, "--domain", std::to_string(d.domain_id),
                                              "--timeout", std::to_string(std::max(30.0, 3 * d.timeout))}),
                        "", {}, nullptr});
  }
  for (const auto& c : children) std::printf("  started %-16s pid %d\n", c.label.c_str(), c.pid);

  // Restart policy of robot processes: restarts pending, and each arm's restart history (intensity).
  struct PendingRestart {
    std::chrono::steady_clock::time_point when;
    Child child;
  };
  std::vector<PendingRestart> pending_restarts;
  std::map<std::string, std::vector<std::chrono::steady_clock::time_point>> restart_history;
  std::map<std::string, int> restarts_of_arm;
  // Returns true if the dead robot c will be restarted (as a standby of lower strength).
  auto schedule_restart = [&](const Child& c) {
    const runtime::ModuleDeployment& m = *c.module;
    const bool wanted = m.restart == "always" || (m.restart == "on-failure" && c.status != 0);
    if (!wanted) return false;
    const auto now = std::chrono::steady_clock::now();
    auto& hist = restart_history[c.arm];
    hist.erase(std::remove_if(hist.begin(), hist.end(),
                              [&](auto t) { return now - t > std::chrono::duration<double>(m.restart_window); }),
               hist.end());
    if (static_cast<int>(hist.size()) >= m.restart_limit) {
      std::printf("tandem up: giving up on %s: %zu restarts within %.0f s (restart_limit %d)\n", c.arm.c_str(),
                  hist.size(), m.restart_window, m.restart_limit);
      return false;
    }
    const int n = ++restarts_of_arm[c.arm];
    const int strength = std::max(1, 30 - n);  // joins as a standby, below the configured ones
    Child next = c;
    next.args.back() = std::to_string(strength);  // the last argument is the strength
    next.label = c.arm + "@" + std::to_string(strength);
    next.running = true;
    next.reported = false;
    next.status = -1;
    const double backoff = m.restart_backoff * std::pow(2.0, static_cast<double>(hist.size()));
    hist.push_back(now);
    std::printf("tandem up: restarting %s as %s in %.2f s (restart %zu of at most %d within %.0f s)\n",
                c.label.c_str(), next.label.c_str(), backoff, hist.size(), m.restart_limit, m.restart_window);
    pending_restarts.push_back({now + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                          std::chrono::duration<double>(backoff)),
                                next});
    return true;
  };

  std::map<std::string, msg::RobotSummary> robots;
  std::map<std::string, msg::WorldSummary> worlds;
  const auto t0 = std::chrono::steady_clock::now();
  auto last_print = t0;
  bool failed = false, stopping = false, coordinator_done = false;
  auto collect = [&] {
    msg::RobotSummary rs;
    while (robot_sum.take(rs)) robots[rs.robot_id()] = rs;
    msg::WorldSummary ws;
    while (world_sum.take(ws)) worlds[ws.module_id()] = ws;
  };
  std::chrono::steady_clock::time_point stop_started{};
  bool escalated = false;
  while (running_count(children) > 0 || (!pending_restarts.empty() && !stopping)) {
    reap(children, false);
    if (stopping && stop_started == std::chrono::steady_clock::time_point{}) stop_started = std::chrono::steady_clock::now();
    if (stopping && !escalated && std::chrono::steady_clock::now() - stop_started > std::chrono::seconds(5)) {
      std::printf("tandem up: %d process(es) did not stop within 5 s; sending SIGKILL\n", running_count(children));
      stop_all(children, SIGKILL);
      escalated = true;
    }
    collect();
    for (auto& c : children) {
      if (!c.running && c.status == 0 && c.label == "coordinator" && !stopping) {
        std::printf("tandem up: the coordinator reports every task done; stopping the deployment\n");
        coordinator_done = true;
        stopping = true;
        stop_all(children, SIGTERM);
      }
      if (!c.running && !stopping && !c.reported && !c.arm.empty() && (c.status != 0 || c.module->restart == "always")) {
        bool served = false;
        for (const auto& o : children) served = served || (o.running && o.arm == c.arm);
        c.reported = true;
        const bool restarting = schedule_restart(c);
        if (served || restarting) {
          std::printf("tandem up: %s exited with code %d; %s\n", c.label.c_str(), c.status,
                      served ? "another robot serves its arm, the deployment goes on"
                             : "its arm waits for the restarted robot");
          continue;
        }
        c.reported = false;  // nobody serves the arm and no restart: a failure (below)
      }
      if (!c.running && c.status != 0 && !stopping && !c.reported) {
        std::fprintf(stderr, "tandem up: %s exited with code %d; stopping the deployment\n", c.label.c_str(), c.status);
        failed = true;
        stopping = true;
        stop_all(children, SIGTERM);
      }
    }
    for (auto it = pending_restarts.begin(); it != pending_restarts.end();) {
      if (stopping || std::chrono::steady_clock::now() < it->when) {
        ++it;
        continue;
      }
      Child c = it->child;
      c.pid = spawn(dir + "/tandem-robot", c.args);
      std::printf("  started %-16s pid %d (restart)\n", c.label.c_str(), c.pid);
      children.push_back(c);
      it = pending_restarts.erase(it);
    }
    msg::ProcessStatus ps;
    while (status.take(ps)) view.update(ps);
    msg::ControlRequest req;
    while (control.take(req)) {
      if (req.deployment() == d.name && req.command() == "down" && !stopping) {
        std::printf("tandem up: 'down' requested over DDS; stopping %d process(es)\n", running_count(children));
        g_stop = true;
      }
      if (req.deployment() == d.name && req.command() == "kill") {
        bool found = false;
        for (const auto& c : children) {
          if (c.label == req.target() && c.running) {
            std::printf("tandem up: fault injection: SIGKILL %s (pid %d)\n", c.label.c_str(), c.pid);
            ::kill(c.pid, SIGKILL);
            found = true;
          }
        }
        if (!found) std::printf("tandem up: 'kill %s': no such running process\n", req.target().c_str());
      }
    }
    if (g_stop && !stopping) {
      std::printf("tandem up: stop requested; stopping %d process(es)\n", running_count(children));
      stopping = true;
      stop_all(children, SIGTERM);
    }
    const auto now = std::chrono::steady_clock::now();
    if (now - last_print > std::chrono::seconds(1)) {
      std::printf("[%5.1f s] processes running %d/%zu\n", std::chrono::duration<double>(now - t0).count(),
                  running_count(children), children.size());
      view.print(stdout);
      std::fflush(stdout);
      last_print = now;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  reap(children, true);
  const auto settle = std::chrono::steady_clock::now();
  while (robots.size() < 2 * d.modules.size() || worlds.size() < d.modules.size()) {
    if (std::chrono::steady_clock::now() - settle > std::chrono::milliseconds(500)) break;
    robot_sum.wait(0.05);
    collect();
  }

  std::printf("\nsummary (%.1f s wall)\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  std::printf("%-14s %8s %12s %12s %12s %10s %10s %9s\n", "arm", "ticks", "e_p Sp RMS", "e_p pos RMS",
              "e_p phi RMS", "e_h RMS N", "min h_n N", "rejected");
  std::ofstream out;
  if (!summary_file.empty()) {
    out.open(summary_file);
    if (!out) std::fprintf(stderr, "tandem up: cannot write the summary to %s\n", summary_file.c_str());
  }
  bool grasp_ok = true;
  for (const auto& m : d.modules) {
    for (const auto& [id, r] : robots) {
      if (id.rfind(m.name + "/", 0) != 0) continue;
      std::printf("%-14s %8llu %12.4e %12.4e %12.4e %10.4f %10.2f %9llu\n", id.c_str(),
                  static_cast<unsigned long long>(r.ticks()), r.ep_sel_rms(), r.ep_pos_rms(), r.ep_ori_rms(),
                  r.eh_rms(), r.min_normal_force(), static_cast<unsigned long long>(r.rejected()));
      if (r.min_normal_force() < h_sg[m.name]) grasp_ok = false;
      if (out) {
        out.precision(17);
        out << id << ".ep_pos_rms=" << r.ep_pos_rms() << "\n" << id << ".ep_ori_rms=" << r.ep_ori_rms() << "\n"
            << id << ".ep_sel_rms=" << r.ep_sel_rms() << "\n" << id << ".eh_rms=" << r.eh_rms() << "\n"
            << id << ".min_normal_force=" << r.min_normal_force() << "\n" << id << ".ticks=" << r.ticks() << "\n"
            << id << ".rejected=" << r.rejected() << "\n";
      }
    }
    const auto w = worlds.find(m.name);
    if (w == worlds.end()) {
      std::printf("%s: no summary from the world\n", m.name.c_str());
      failed = true;
      continue;
    }
    const msg::WorldSummary& ws = w->second;
    std::printf("%s: %llu ticks, object at (%.6f, %.6f), slips %llu, contact lost %llu, rejected commands %llu, "
                "%s %llu\n",
                m.name.c_str(), static_cast<unsigned long long>(ws.ticks()), ws.object_final()[0],
                ws.object_final()[1], static_cast<unsigned long long>(ws.slip_events()),
                static_cast<unsigned long long>(ws.contact_lost()),
                static_cast<unsigned long long>(ws.rejected_commands()),
                ws.realtime() ? "late arm-ticks" : "timeouts", static_cast<unsigned long long>(ws.late_commands()));
    if (ws.failovers() > 0) {
      std::printf("%s: %llu failover(s): the world switched robots after a gap of %.1f ms (worst %.1f ms)\n",
                  m.name.c_str(), static_cast<unsigned long long>(ws.failovers()), ws.failover_last_ms(),
                  ws.failover_max_ms());
    }
    if (ws.realtime()) {
      std::printf("%s: real time: sample->command latency p50 %.0f us, p99 %.0f us, max %.0f us; late arm-ticks %llu "
                  "of %llu (%.2f%%); world tick start late p99 %.0f us\n",
                  m.name.c_str(), ws.latency_p50_us(), ws.latency_p99_us(), ws.latency_max_us(),
                  static_cast<unsigned long long>(ws.late_commands()), 2ULL * ws.ticks(),
                  ws.ticks() > 0 ? 50.0 * static_cast<double>(ws.late_commands()) / static_cast<double>(ws.ticks()) : 0.0,
                  ws.wake_late_p99_us());
    }
    if (ws.slip_events() > 0 || ws.contact_lost() > 0) grasp_ok = false;
    if (out) {
      out << m.name << ".ticks=" << ws.ticks() << "\n" << m.name << ".slip_events=" << ws.slip_events() << "\n"
          << m.name << ".contact_lost=" << ws.contact_lost() << "\n" << m.name
          << ".rejected_commands=" << ws.rejected_commands() << "\n" << m.name
          << ".late_commands=" << ws.late_commands() << "\n" << m.name << ".latency_p50_us=" << ws.latency_p50_us()
          << "\n" << m.name << ".latency_p99_us=" << ws.latency_p99_us() << "\n" << m.name
          << ".failovers=" << ws.failovers() << "\n" << m.name << ".failover_max_ms=" << ws.failover_max_ms() << "\n";
      for (size_t i = 0; i < 6; ++i) out << m.name << ".q_final" << i << "=" << ws.q_final()[i] << "\n";
      for (size_t i = 0; i < 3; ++i) out << m.name << ".object_final" << i << "=" << ws.object_final()[i] << "\n";
    }
  }
  for (const auto& c : children) {
    if (c.status != 0) {
      std::printf("process %s exited with code %d%s\n", c.label.c_str(), c.status,
                  c.reported ? " (restarted, or its arm was served by another robot)" : "");
    }
  }
  {
    msg::ProcessStatus ps;
    while (status.take(ps)) view.update(ps);
    std::printf("final states:\n");
    view.print(stdout);
  }
  // A process killed by a signal could not remove its shared-memory files: clean the segments and ports
  // that no live participant uses (best effort, with Fast DDS's own tool).
  bool killed = false;
  for (const auto& c : children) killed = killed || c.status >= 128;
  if (killed && std::system("fastdds shm clean > /dev/null 2>&1") != 0) {
    std::printf("note: 'fastdds shm clean' failed; stale files may remain in /dev/shm\n");
  }
  if (d.coordinator && !coordinator_done) failed = true;
  const bool ok = !failed && !g_stop && grasp_ok;
  if (out && d.coordinator) out << "coordinator.done=" << (coordinator_done ? 1 : 0) << "\n";
  std::printf("result: %s\n", ok ? "PASS (all processes finished, safe grasp kept)"
                                 : (g_stop ? "STOPPED" : "FAIL (see above)"));
  return ok ? 0 : 1;
}

}  // namespace tandem::cli
