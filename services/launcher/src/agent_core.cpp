#include "tandem/launcher/agent_core.hpp"
#include "tandem/launcher/spawn.hpp"

#include <csignal>
#include <cstdio>

namespace tandem::launcher {

AgentCore::AgentCore(Processes& p, std::string dir, double host_timeout, double now)
    : p_(p), dir_(std::move(dir)), host_timeout_(host_timeout), launcher_heard_(now) {}

int AgentCore::running() const {
  int n = 0;
  for (const auto& c : children_) n += c.running ? 1 : 0;
  return n;
}

bool AgentCore::take_killed() {
  const bool k = killed_;
  killed_ = false;
  return k;
}

void AgentCore::note(const std::string& s) {
  detail_ = s;
  log(s);
}

void AgentCore::on_request(const AgentRequestIn& r, double now) {
  if (r.run == 0) return;
  if (r.run != run_) {
    if (r.kind == AgentRequestIn::Kind::End) return;  // the end of a run this agent does not serve
    // First come, first served: another launcher of this deployment while the one served lives is refused.
    if (run_ != 0 && !run_over_ && silent(now) <= host_timeout_) {
      if (refused_runs_.insert(r.run).second) {
        note("refused requests of another launcher run (" + std::to_string(r.run) + ") while serving run " +
             std::to_string(run_) + ": is a second `tandem up` of this deployment running?");
      }
      return;
    }
    new_run(r.run, now);
  }
  launcher_heard_ = now;
  switch (r.kind) {
    case AgentRequestIn::Kind::Heartbeat:
      if (r.host_lost) {
        // One-way partition: this agent hears the launcher, but the launcher does not hear it.
        fence("the launcher counts this host as lost (it does not hear this agent)", now);
      } else if (fenced_) {
        // A healed partition: the launcher may place processes here again (it counted the fenced ones as failed).
        fenced_ = false;
        log("the launcher is heard again; serving it again");
      }
      return;
    case AgentRequestIn::Kind::Start:
      start(r);
      return;
    case AgentRequestIn::Kind::Signal:
      send_signal(r, now);
      return;
    case AgentRequestIn::Kind::End:
      if (!run_over_) {
        run_over_ = true;
        if (running() > 0) {
          log("the launcher's run is over; stopping " + std::to_string(running()) + " leftover process(es)");
          stop_all(SIGTERM, now);
        }
      }
      return;
    case AgentRequestIn::Kind::Unknown:
      break;
  }
  note("refused a request of unknown kind " + std::to_string(r.raw_kind) + " (accepted: start, signal, heartbeat, end)");
}

void AgentCore::poll(double now) {
  for (auto& c : children_) {
    if (!c.running) continue;
    const int st = p_.reap(c.pid);
    if (st >= 0) {
      c.running = false;
      c.status = st;
      log(c.label + " (pid " + std::to_string(c.pid) + ") exited with code " + std::to_string(st));
      if (st >= 128) killed_ = true;
    } else if (c.term_at >= 0.0 && now - c.term_at > kKillAfterTermS) {
      log(c.label + " did not stop within 5 s of SIGTERM; SIGKILL");
      p_.signal(c.pid, SIGKILL);
      c.term_at = -1.0;
    }
  }
  if (!run_over_ && served() && silent(now) > host_timeout_) {
    char why[96];
    std::snprintf(why, sizeof why, "the launcher has been silent for %.1f s", silent(now));
    fence(why, now);
  }
}

void AgentCore::stop_all(int sig, double now) {
  for (auto& c : children_) {
    if (!c.running) continue;
    p_.signal(c.pid, sig);
    if (sig == SIGTERM && c.term_at < 0.0) c.term_at = now;
    if (sig == SIGKILL) killed_ = true;
  }
}

void AgentCore::new_run(unsigned long long run, double now) {
  if (running() > 0) {
    log("a new launcher run (" + std::to_string(run) + "); stopping the " + std::to_string(running()) +
        " process(es) of the previous one");
    stop_all(SIGKILL, now);
  }
  log("serving launcher run " + std::to_string(run));
  run_ = run;
  run_over_ = false;
  fenced_ = false;
  // The previous run's children are forgotten (their spawn ids are the old run's); running ones until reaped.
  std::vector<AgentChild> keep;
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

void AgentCore::fence(const std::string& why, double now) {
  // This host counts as lost (standbys elsewhere serve its slots), so what it runs is killed, so that no primary
  // comes back beside its replacement.
  if (fenced_ || running() == 0) return;
  log(why + ": this host counts as lost, standbys elsewhere serve its slots; SIGKILL to its " +
      std::to_string(running()) + " process(es) (fencing)");
  stop_all(SIGKILL, now);
  fenced_ = true;
}

void AgentCore::start(const AgentRequestIn& r) {
  if (!seen_.insert(r.spawn_id).second) return;  // re-sent: done already
  AgentChild c;
  c.spawn_id = r.spawn_id;
  c.label = r.label;
  const auto tomb = tombstones_.find(r.spawn_id);
  if (tomb != tombstones_.end()) {  // signalled before it was started: it never runs
    c.status = 128 + tomb->second;
    children_.push_back(c);
    return;
  }
  static const std::set<std::string> kRoles{"world", "supervisor", "robot", "coordinator"};
  if (kRoles.count(r.role) == 0) {
    note("refused to start '" + r.label + "': unknown role '" + r.role + "' (accepted: world, supervisor, robot, coordinator)");
    c.status = 127;
    children_.push_back(c);
    return;
  }
  if (run_over_) {
    note("refused to start '" + r.label + "': the launcher's run is over");
    c.status = 127;
    children_.push_back(c);
    return;
  }
  Processes::Spec s;
  s.exe = dir_ + "/tandem-" + r.role;  // never a path from the wire
  s.args = r.args;
  s.rt_priority = rt_permitted ? r.rt_priority : 0;
  s.participant_id = r.participant_id;
  s.identity = r.identity;
  s.own_group = own_group_for(r.role, r.args);
  if (r.role != "coordinator") s.module = r.label.substr(0, r.label.find('/'));
  c.pid = p_.start(s);
  c.running = c.pid > 0;
  c.status = c.running ? -1 : 127;
  if (!c.running) note("could not start '" + r.label + "' (" + s.exe + ")");
  char line[160];
  std::snprintf(line, sizeof line, "started %-22s pid %d", c.label.c_str(), c.pid);
  log(line);
  children_.push_back(c);
}

void AgentCore::send_signal(const AgentRequestIn& r, double now) {
  const int sig = r.signal;
  if (sig != SIGTERM && sig != SIGKILL && sig != SIGINT) {
    note("refused signal " + std::to_string(sig) + " for '" + r.label + "' (accepted: 2, 9, 15)");
    return;
  }
  for (auto& c : children_) {
    if (c.spawn_id != r.spawn_id) continue;
    if (c.running) {
      p_.signal(c.pid, sig);
      if (sig == SIGTERM && c.term_at < 0.0) c.term_at = now;
    }
    return;
  }
  tombstones_[r.spawn_id] = sig;
}

}  // namespace tandem::launcher
