// The launcher's supervision (launcher::Supervisor): see supervisor.hpp. Times are seconds since the launcher
// started, passed in; processes are started and signalled through the Executor; everything said goes out through
// the Outbox.
#include "tandem/launcher/supervisor.hpp"

#include <algorithm>
#include <csignal>
#include <cstdarg>
#include <cstdio>
#include <optional>
#include <utility>

#include "tandem/launcher/exit_rules.hpp"
#include "tandem/plan/plan.hpp"

namespace tandem::launcher {
namespace {

std::string vformat(const char* fmt, va_list ap) {
  va_list copy;
  va_copy(copy, ap);
  const int n = std::vsnprintf(nullptr, 0, fmt, copy);
  va_end(copy);
  if (n <= 0) return {};
  std::string s(static_cast<size_t>(n) + 1, '\0');
  std::vsnprintf(s.data(), s.size(), fmt, ap);
  s.resize(static_cast<size_t>(n));
  return s;
}

constexpr int kTaskNone = -1;  ///< no task state heard from the module
constexpr int code(plan::TaskStateCode c) { return static_cast<int>(c); }

}  // namespace

Supervisor::Supervisor(SupervisorConfig cfg, Executor& exec, Outbox& out)
    : cfg_(std::move(cfg)), exec_(exec), out_(out) {
  for (int i = cfg_.first_participant_id; i < cfg_.end_participant_id; ++i) free_ids_.push_back(i);
  if (!cfg_.hosts.empty()) hosts_ = std::make_unique<HostWatch>(cfg_.hosts, cfg_.host_timeout);
}

void Supervisor::logf(const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  std::string line = vformat(fmt, ap);
  va_end(ap);
  out_.log(line, false);
}

void Supervisor::errf(const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  std::string line = vformat(fmt, ap);
  va_end(ap);
  out_.log(line, true);
}

/// Logs a command's outcome and keeps it as the launcher's answer (its status detail), which the
/// `tandem plug/unplug/kill` that sent the request waits for.
void Supervisor::say(bool ok, const char* fmt, ...) {
  char buf[512];
  va_list ap;
  va_start(ap, fmt);
  std::vsnprintf(buf, sizeof buf, fmt, ap);
  va_end(ap);
  out_.log(std::string("tandem up: ") + buf, false);
  std::string text(buf);
  while (!text.empty() && text.back() == '\n') text.pop_back();
  if (current_seq_ == 0) return;  // no live command's (seq 0: the launcher's own requests)
  const auto [it, fresh] = answers_.try_emplace(current_seq_);
  Answer& a = it->second;
  if (fresh) {
    a = Answer{ok, text};
  } else {  // a further line for the same request (e.g. kill of a module)
    a.text += "; " + text;
    a.ok = a.ok && ok;
  }
  while (answers_.size() > 256 && answers_.begin()->first != current_seq_) answers_.erase(answers_.begin());
}

const Supervisor::Answer* Supervisor::answer(unsigned long long seq) const {
  const auto it = answers_.find(seq);
  return it == answers_.end() ? nullptr : &it->second;
}

// ---- set-up -------------------------------------------------------------------------------------------------

void Supervisor::add_module(ModuleSpec spec) {
  ModuleRun run;
  run.spec = std::move(spec);
  const std::string name = run.spec.name;
  modules_[name] = std::move(run);
}

void Supervisor::start_module(const std::string& name, double now) {
  ModuleRun& mr = modules_.at(name);
  const ModuleSpec& m = mr.spec;
  mr.started = true;
  mr.end = {};
  mr.task_over = false;
  mr.ticked = false;
  mr.started_at = now;
  mr.load_paused_since = -1.0;
  Child w;
  w.label = m.name + "/world";
  w.role = "world";
  w.module = m.name;
  w.host = exec_.place(w);
  launch(w, "", now);
  for (int i = 0; i <= m.supervisor_standby; ++i) {
    start_supervisor(m.name, i == 0 ? kPrimaryStrength : 60 - 10 * i, "", now);
  }
  for (const auto& robot : mr.spec.robots) {
    for (int i = 0; i <= m.standby; ++i) {
      // The primary has strength 100; standbys 50, 40, ...: the world follows the strongest live one.
      start_robot(m.name, robot, i == 0 ? kPrimaryStrength : 60 - 10 * i, "", now);
    }
  }
}

void Supervisor::start_modules(const std::vector<std::string>& names, double now) {
  if (!cfg_.start_one_by_one) {
    for (const auto& n : names) start_module(n, now);
    return;
  }
  start_queue_.assign(names.begin(), names.end());
  last_queued_start_.clear();
  start_queued(now);
}

/// module_start: one_by_one. A participant of simple discovery announces itself to every other it knows of; 32 of
/// them starting together kept three of four modules from coming up in a soak (docs/benchmarks.md item 35), so the
/// next module starts once the last one's world has ticked (its participants have found each other), or after
/// start_gap_max whatever the last one does (a module that does not come up is repaired by its own rule).
void Supervisor::start_queued(double now) {
  while (!start_queue_.empty()) {
    if (stopping_) {
      start_queue_.clear();
      return;
    }
    if (!last_queued_start_.empty()) {
      const ModuleRun& last = modules_.at(last_queued_start_);
      const bool its_turn_over = last.ticked || !last.end.running() || !last.started ||
                                 now - last_queued_start_at_ >= cfg_.start_gap_max;
      if (!its_turn_over) return;
    }
    const std::string next = start_queue_.front();
    start_queue_.pop_front();
    const ModuleRun& mr = modules_.at(next);
    if (mr.started) continue;  // started meanwhile (a `tandem plug module`)
    if (!last_queued_start_.empty()) {
      logf("tandem up: starting module %s (modules start one by one: %s %s)\n", next.c_str(),
           last_queued_start_.c_str(), modules_.at(last_queued_start_).ticked ? "ticks" : "had its turn");
    }
    start_module(next, now);
    last_queued_start_ = next;
    last_queued_start_at_ = now;
  }
}

void Supervisor::start_coordinators(double now) {
  if (!cfg_.coordinated) return;
  for (int i = 0; i <= cfg_.coordinator_standby; ++i) {
    start_coordinator(i == 0 ? "coordinator" : "coordinator@standby" + std::to_string(i), i > 0, "", now);
  }
}

void Supervisor::start_coordinator(const std::string& id, bool standby, const char* note, double now) {
  Child c;
  c.label = id;
  c.role = "coordinator";
  c.standby = standby;
  // A restart: the queue has a history, so it must take over with its state, never afresh.
  c.resume = std::string(note) == " (restart)";
  c.host = exec_.place(c);
  launch(c, note, now);
}

/// Starts a robot for `module`/`robot` with the given strength; false if the process could not be started.
bool Supervisor::start_robot(const std::string& module, const std::string& robot, int strength, const char* note,
                             double now) {
  return start_ranked("robot", module, robot, strength, note, now);
}

/// Starts a supervisor for `module`: the primary (strength 100) or a standby (lower).
void Supervisor::start_supervisor(const std::string& module, int strength, const char* note, double now) {
  start_ranked("supervisor", module, "supervisor", strength, note, now);
}

/// A process that serves a slot of a module by strength (an arm's robot, the module's supervisor): its slot is kept
/// in Child::arm (standby strengths and live counts are per slot), its label is the slot, with "@strength" for a
/// standby.
bool Supervisor::start_ranked(const char* role, const std::string& module, const std::string& slot, int strength,
                              const char* note, double now) {
  Child c;
  c.arm = module + "/" + slot;
  c.label = c.arm + (strength == kPrimaryStrength ? "" : "@" + std::to_string(strength));
  c.role = role;
  c.module = module;
  c.strength = strength;
  c.standby = strength != kPrimaryStrength;
  c.host = exec_.place(c);
  return launch(c, note, now);
}

std::vector<std::string> Supervisor::admit(const std::vector<std::string>& order, size_t fit, double now) {
  governor_ = std::make_unique<Governor>(order);
  std::vector<std::string> parked = governor_->admit(fit, now);
  for (const std::string& m : parked) modules_.at(m).end = ModuleEnd::of(ModuleEnd::Kind::Parked, "admission");
  return parked;
}

/// Starts `c` (here, or by its host's agent); false if it could not be started.
bool Supervisor::launch(Child& c, const char* note, double now) {
  // The participant id left longest ago (see services/dds/src/participant.cpp); none left: Fast DDS picks.
  c.participant_id = -1;
  bool reused_ports = false;
  if (!free_ids_.empty()) {
    // The longest-free id whose old port files are gone (removed, or never made); none such: the longest-free id.
    auto pick = free_ids_.begin();
    if (has_old_ports_) {
      const auto fresh = std::find_if(free_ids_.begin(), free_ids_.end(), [this](int id) { return !has_old_ports_(id); });
      if (fresh != free_ids_.end()) pick = fresh;
      reused_ports = fresh == free_ids_.end();
    }
    c.participant_id = *pick;
    free_ids_.erase(pick);
  }
  // Said in the log: a newcomer that reopens a killed process's port files is the suspect of soak findings 59 and 69
  // (new readers heard nothing for tens of seconds), and this tells those starts from the others.
  std::string said = note;
  if (reused_ports) said += " (participant id " + std::to_string(c.participant_id) + ": every free id still had port files)";
  c.running = true;
  c.started = now;
  c.heard = false;
  if (c.host.empty()) {
    c.pid = exec_.start(c);
    logf("  started %-22s pid %d%s\n", c.label.c_str(), c.pid, said.c_str());
  } else if (hosts_ != nullptr && hosts_->lost(c.host)) {
    logf("  cannot start %-18s on %s: the host is lost%s\n", c.label.c_str(), c.host.c_str(), said.c_str());
    c.pid = -1;
    mark_exited(c, 127);
  } else {
    c.pid = 0;  // known when the agent reports it
    c.spawn_id = ++spawns_;
    c.acked = false;
    c.signal = 0;
    (void)exec_.start(c);
    c.sent = now;
    logf("  started %-22s on %s%s\n", c.label.c_str(), c.host.c_str(), said.c_str());
  }
  children_.push_back(c);
  return c.running && (c.pid > 0 || !c.host.empty());
}

// ---- counts ---------------------------------------------------------------------------------------------------

/// Strength for a new standby of `arm` (next_standby_strength over the live robots of the arm).
int Supervisor::standby_strength(const std::string& arm) const {
  std::vector<int> live;
  for (const auto& c : children_) {
    if (c.running && c.arm == arm) live.push_back(c.strength);
  }
  return next_standby_strength(live);
}

const Child* Supervisor::primary_of(const std::string& arm) const {
  for (const auto& c : children_) {
    if (c.running && !c.expected && c.arm == arm && c.strength == kPrimaryStrength) return &c;
  }
  return nullptr;
}

int Supervisor::live_robots(const std::string& arm, const Child* except) const {
  int n = 0;
  for (const auto& c : children_) n += (c.running && !c.expected && c.arm == arm && &c != except) ? 1 : 0;
  return n;
}

int Supervisor::running() const {
  int n = 0;
  for (const auto& c : children_) n += c.running ? 1 : 0;
  return n;
}

bool Supervisor::busy() const { return running() > 0 || (!pending_restarts_.empty() && !stopping_); }

const Child* Supervisor::leader_of(const std::string& slot, const Child* except) const {
  for (const auto& c : children_) {
    if (c.running && !c.expected && c.arm == slot && c.leads && &c != except && polled_at_ - c.status_at < 0.5) return &c;
  }
  return nullptr;
}

int Supervisor::live_coordinators() const {
  int n = 0;
  for (const auto& c : children_) n += (c.running && c.role == "coordinator") ? 1 : 0;
  return n;
}

Child* Supervisor::find_running(const std::string& label) {
  for (auto& c : children_) {
    if (c.running && c.label == label) return &c;
  }
  return nullptr;
}

bool Supervisor::module_gone(const std::string& module) const {
  bool gone = true;
  for (const auto& c : children_) gone = gone && !(c.running && c.module == module);
  return gone;
}

int Supervisor::task_state(const std::string& module) const {
  const auto it = task_states_.find(module);
  return it == task_states_.end() ? kTaskNone : it->second;
}

std::string Supervisor::parked_text() const {
  std::string out;
  if (!governor_) return out;
  for (const auto& m : governor_->parked_set()) out += (out.empty() ? "" : ", ") + m;
  return out;
}

// ---- live commands ----------------------------------------------------------------------------------------------

void Supervisor::on_request(const Request& r, double now) {
  if (stopping_) {
    refuse_while_stopping(r);
  } else {
    handle(r, now);
  }
}

void Supervisor::handle(const Request& req, double now) {
  // Requests are re-sent until answered: carry each out once.
  if (req.seq != 0 && !handled_seqs_.insert(req.seq).second) return;
  current_seq_ = req.seq;
  switch (req.command) {
    case Request::Command::Down:
      if (!stopping_) say(true, "'down' requested over DDS; stopping %d process(es)\n", running());
      down_requested_ = true;
      break;
    case Request::Command::Kill:
      kill_target(req.target, now);
      break;
    case Request::Command::Plug:
      plug(req, now);
      break;
    case Request::Command::Unplug:
      unplug(req, now);
      break;
    case Request::Command::Other:
      say(false, "unknown command %d (accepted: down, kill, plug, unplug)\n", req.raw_command);
  }
}

/// The answer to a request that came while the deployment stops: nothing is carried out.
void Supervisor::refuse_while_stopping(const Request& req) {
  if (req.seq != 0 && !handled_seqs_.insert(req.seq).second) return;
  current_seq_ = req.seq;
  if (req.command == Request::Command::Down) {
    say(true, "'down' requested over DDS; the deployment is already stopping\n");
  } else {
    // As the user typed it: "plug robot m1/left", "unplug module m2", "kill m1/world".
    const bool kill = req.command == Request::Command::Kill;
    const char* kind = req.target_kind == Request::Target::Module && !kill ? "module "
                       : req.target_kind == Request::Target::Robot ||
                                 (req.target_kind == Request::Target::Process && req.command == Request::Command::Unplug)
                           ? "robot "
                           : "";
    say(false, "'%s %s%s' refused: the deployment is stopping\n", req.command_name.c_str(), kind, req.target.c_str());
  }
}

void Supervisor::kill_target(const std::string& target, double now) {
  bool found = false;
  for (auto& c : children_) {
    if (!c.running) continue;
    if (c.label == target || (c.module == target && !target.empty())) {
      say(true, "fault injection: SIGKILL %s (pid %d%s%s)\n", c.label.c_str(), c.pid, c.host.empty() ? "" : " on ",
          c.host.c_str());
      signal_child(c, SIGKILL, now);
      found = true;
    }
  }
  if (!found) say(false, "'kill %s': no such running process or module\n", target.c_str());
}

/// What the plug and unplug rules need to know of a module (ModuleFacts).
ModuleFacts Supervisor::module_facts(const std::string& name) const {
  ModuleFacts f;
  const auto it = modules_.find(name);
  if (it == modules_.end()) return f;
  f.known = true;
  f.started = it->second.started;
  f.end = it->second.end;
  f.failed = task_state(name) == code(plan::TaskStateCode::Failed);
  for (size_t i = 0; i < 2 && i < it->second.spec.robots.size(); ++i) f.arms[i] = it->second.spec.robots[i];
  return f;
}

void Supervisor::plug(const Request& req, double now) {
  const std::string& name = req.target;
  if (req.target_kind == Request::Target::Module) {
    plug_module(name, req.scenario, req.case_name, req.host, now);
    return;
  }
  if (req.target_kind != Request::Target::Robot) {
    say(false, "'plug %s': expected a robot for an arm (<module>/<arm>) or a module\n", name.c_str());
    return;
  }
  const auto slash = name.find('/');
  const std::string module = name.substr(0, slash), robot = slash == std::string::npos ? "" : name.substr(slash + 1);
  const Child* primary = primary_of(name);
  const PlugDecision dec = plug_robot(name, robot, req.standby, module_facts(module),
                                      primary != nullptr ? primary->pid : 0, standby_strength(name));
  if (dec.action == PlugDecision::Action::Refuse) {
    say(false, "%s\n", dec.text.c_str());
    return;
  }
  if (!start_robot(module, robot, dec.strength, " (plugged)", now)) {
    say(false, "'plug robot %s': the process could not be started\n", name.c_str());
    return;
  }
  say(true, "%s\n", dec.text.c_str());
  resume_if_paused_for_unplug(module);
}

/// Plugs a module in again (one of the deployment, or one failed by a drop: cleared), or a new one from a scenario
/// and case (on `host` in a multi-host deployment).
void Supervisor::plug_module(const std::string& name, const std::string& scenario, const std::string& case_name,
                             const std::string& host, double now) {
  using Action = PlugDecision::Action;
  const PlugDecision dec =
      launcher::plug_module(name, module_facts(name), !scenario.empty(), !case_name.empty(), cfg_.deployment_file);
  switch (dec.action) {
    case Action::Refuse:
      say(false, "%s\n", dec.text.c_str());
      return;
    case Action::ClearModule:
      say(true, "%s\n", dec.text.c_str());
      task_states_.erase(name);
      modules_.at(name).end = ModuleEnd::of(ModuleEnd::Kind::Cleared);
      modules_.at(name).spin_repairs = 0;  // a person plugged it: its spin repairs count from 0 again
      if (governor_) governor_->set_available(name, true);
      stop_module(name, now);
      pending_clears_.push_back(name);  // started again once its processes are gone
      return;
    case Action::AddModule:
      if (!add_plugged_module(name, scenario, case_name, host)) return;
      break;
    case Action::StartModule:
    case Action::StartRobot:
      break;
  }
  const bool waiting = std::find(pending_clears_.begin(), pending_clears_.end(), name) != pending_clears_.end();
  if (waiting) {
    say(false, "'plug module %s': it starts already, once its previous processes have stopped\n", name.c_str());
    return;
  }
  if (dec.action != Action::StartRobot) modules_.at(name).spin_repairs = 0;  // a person plugged it: 3 repairs again
  // Its previous processes may still be stopping (a plug right after an unplug's drain): the new ones start once
  // they are gone, so that none of them hears an old one (soak run 53: a module plugged back the moment its drain
  // ended stood "running" with no task for 50 s while the coordinator waited for it to be free).
  const bool old_ones_stopping = !module_gone(name);
  say(true, "plugging module %s (%s, case %s)%s\n", name.c_str(), modules_.at(name).spec.scenario.c_str(),
      modules_.at(name).spec.case_name.c_str(), old_ones_stopping ? "; it starts once its previous processes have stopped" : "");
  if (governor_) {  // plugged by hand: out of the governor's parked set, and in its hands again
    governor_->set_available(name, false);
    governor_->set_available(name, true);
  }
  if (old_ones_stopping) {
    pending_clears_.push_back(name);
    return;
  }
  start_module(name, now);
}

/// A new module from a scenario and case: its host checked (multi-host), its scenario loaded and its case found.
bool Supervisor::add_plugged_module(const std::string& name, const std::string& scenario, const std::string& case_name,
                                    const std::string& host) {
  if (!cfg_.hosts.empty()) {
    if (host.empty() || std::find(cfg_.hosts.begin(), cfg_.hosts.end(), host) == cfg_.hosts.end()) {
      std::string list;
      for (const auto& x : cfg_.hosts) list += (list.empty() ? "" : ", ") + x;
      say(false, "'plug module %s': a multi-host deployment places a new module on a host: give --host (hosts: %s)\n",
          name.c_str(), list.c_str());
      return false;
    }
  }
  bool found = false;
  try {
    add_module(out_.load_module(name, scenario, case_name, cfg_.hosts.empty() ? "" : host, found));
  } catch (const std::exception& e) {
    say(false, "'plug module %s': %s\n", name.c_str(), e.what());
    return false;
  }
  if (!found) {
    modules_.erase(name);
    say(false, "'plug module %s': no case '%s' in %s\n", name.c_str(), case_name.c_str(), scenario.c_str());
    return false;
  }
  return true;
}

void Supervisor::unplug(const Request& req, double now) {
  const std::string& name = req.target;
  using Action = UnplugDecision::Action;
  if (req.target_kind == Request::Target::Module) {
    const UnplugDecision dec = unplug_module(name, module_facts(name));
    say(dec.action != Action::Refuse, "%s\n", dec.text.c_str());
    if (dec.action == Action::Refuse) return;
    ModuleRun& mr = modules_.at(name);
    mr.end = ModuleEnd::of(ModuleEnd::Kind::Draining);
    mr.drain.start(now);
    if (governor_) governor_->set_available(name, false);
    send(name, ModuleCommand::Drain);
    return;
  }
  if (req.target_kind != Request::Target::Process) {
    say(false, "'unplug %s': expected a robot's label or a module\n", name.c_str());
    return;
  }
  Child* c = find_running(name);
  if (c != nullptr && c->role != "robot") c = nullptr;
  const UnplugDecision dec = unplug_robot(name, c != nullptr, c ? c->arm : "", c ? c->module : "",
                                          c ? live_robots(c->arm, c) : 0);
  say(dec.action != Action::Refuse, "%s\n", dec.text.c_str());
  if (dec.action == Action::Refuse || c == nullptr) return;  // (refused when no running robot has the label)
  c->expected = true;
  if (dec.action == Action::HandOver) {
    terminate(*c, now);  // it deletes its torque writer first: the world follows the next strongest at once
    return;
  }
  modules_.at(c->module).paused_for_unplug = true;
  send(c->module, ModuleCommand::Pause);
  pending_unplugs_.push_back({c->label, c->module, now});
}

void Supervisor::resume_if_paused_for_unplug(const std::string& module) {
  ModuleRun& mr = modules_.at(module);
  if (!mr.paused_for_unplug) return;
  mr.paused_for_unplug = false;
  send(module, ModuleCommand::Resume);  // it resumes once the arm's new robot answers (the world releases the brake)
}

void Supervisor::send(const std::string& module, ModuleCommand command) { out_.control(module, command, ++seq_); }

// ---- what is heard ------------------------------------------------------------------------------------------------

void Supervisor::on_exit(int pid, int status) {
  for (auto& c : children_) {
    if (c.running && c.host.empty() && c.pid == pid && pid > 0) {
      mark_exited(c, status);
      return;
    }
  }
}

const Child* Supervisor::on_status(const std::string& label, long long pid, bool active, bool serving_known,
                                   bool leads) {
  const Child* first_active = nullptr;
  for (auto& c : children_) {
    if (!(c.running && c.label == label && c.pid == pid)) continue;
    c.heard = true;
    c.status_at = polled_at_;
    if (serving_known) c.leads = leads;
    if (active && !c.active_seen && c.host.empty()) {
      c.active_seen = true;
      first_active = &c;
    }
  }
  return first_active;
}

void Supervisor::on_world_done(const std::string& label, long long pid, double now) {
  if (cfg_.coordinated) return;  // a coordinated module's world runs until stopped: its task is never over alone
  for (auto& c : children_) {
    if (!(c.running && c.role == "world" && c.label == label && c.pid == pid) || c.done_said >= 0.0) continue;
    c.done_said = now;
    if (!c.module.empty()) modules_.at(c.module).task_over = true;
  }
}

void Supervisor::on_spun(int pid) {
  for (auto& c : children_) {
    if (c.running && c.host.empty() && c.pid == pid && pid > 0) c.spun = true;
  }
}

void Supervisor::on_world_load(const std::string& module, const std::string& detail, unsigned long long tick,
                               double now) {
  const auto it = modules_.find(module);
  const bool paused = detail.rfind("paused for load", 0) == 0;
  if (it != modules_.end()) {
    if (tick > 0) it->second.ticked = true;
    double& since = it->second.load_paused_since;
    since = paused ? (since < 0.0 ? now : since) : -1.0;
  }
  if (!governor_ || stopping_) return;
  if (it == modules_.end() || !it->second.started || !it->second.end.running()) return;
  governor_->on_load(module, paused, now);
}

void Supervisor::on_task_state(const std::string& module, int state) {
  const auto it = task_states_.find(module);
  const bool newly_failed = state == code(plan::TaskStateCode::Failed) && (it == task_states_.end() || it->second != state);
  task_states_[module] = state;
  // A module failed by a drop takes no task until it is cleared: not a running module to the governor (which then
  // unparks another if no module runs; soak run 53: m1 failed while m2 was parked, and no task was done for 80 s).
  if (newly_failed && governor_) governor_->set_available(module, false);
}

Supervisor::QueueState Supervisor::on_coordinator_state(unsigned long long next_task_id, unsigned long long done_total,
                                                       size_t done) {
  const bool more = !have_coord_state_ || next_task_id > coord_next_ ||
                    (next_task_id == coord_next_ && done_total > coord_total_);
  if (!more && !(next_task_id == coord_next_ && done_total == coord_total_)) return QueueState::Older;
  have_coord_state_ = true;
  coord_next_ = next_task_id;
  coord_total_ = done_total;
  coord_done_ = done;
  return more ? QueueState::Advanced : QueueState::Same;
}

// ---- supervision ----------------------------------------------------------------------------------------------

void Supervisor::poll(double now) {
  polled_at_ = now;
  for (auto& c : children_) {  // never started here
    if (c.host.empty() && c.running && c.pid <= 0) {
      c.running = false;
      c.status = 127;
    }
  }
  watch_hosts(now);
  start_queued(now);
  resend_drains(now);
  for (auto& c : children_) {
    if (c.running || c.handled) continue;
    c.handled = true;
    handle_exit(c, now);
  }
  // Failed modules being cleared: started again once every process of theirs is gone.
  for (auto it = pending_clears_.begin(); it != pending_clears_.end();) {
    if (!module_gone(*it) || stopping_) {
      it = stopping_ ? pending_clears_.erase(it) : it + 1;
      continue;
    }
    const ModuleEnd& end = modules_.at(*it).end;
    logf("tandem up: module %s %s; starting it again from its initial grasp\n", it->c_str(),
         end.is(ModuleEnd::Kind::Repairing)    ? "stopped for the repair"
         : end.is(ModuleEnd::Kind::Unplugged) ? "plugged in, its previous processes stopped"
                                               : "cleared");
    start_module(*it, now);
    it = pending_clears_.erase(it);
  }
  // Unplugs waiting for their module to be at rest.
  for (auto it = pending_unplugs_.begin(); it != pending_unplugs_.end();) {
    const bool paused = task_state(it->module) == code(plan::TaskStateCode::Paused);
    const bool late = now - it->since > 5.0;
    Child* c = find_running(it->label);
    if (c == nullptr) {
      it = pending_unplugs_.erase(it);
      continue;
    }
    if (!paused && !late) {
      ++it;
      continue;
    }
    if (!paused) {
      logf("tandem up: %s did not report paused within 5 s; unplugging %s anyway (the brakes hold the arm)\n",
           it->module.c_str(), c->label.c_str());
    }
    logf("tandem up: %s paused; %s leaves, its arm is braked until a robot is plugged in\n", it->module.c_str(),
         c->label.c_str());
    terminate(*c, now);
    it = pending_unplugs_.erase(it);
  }
  // A world that said its task is done but does not exit (hung in its teardown): stopped, and its task is over.
  for (auto& c : children_) {
    if (!c.running || c.done_said < 0.0 || c.term_at >= 0.0 || c.expected || now - c.done_said < kWorldExitGraceS) continue;
    logf("tandem up: %s said its task is done %.1f s ago and has not exited; stopping it (its task is over)\n",
         c.label.c_str(), now - c.done_said);
    c.expected = true;
    terminate(c, now);
    world_done_.emplace(c.module, now);
  }
  for (auto it = world_done_.begin(); it != world_done_.end();) {
    if (now - it->second < 2.0) {
      ++it;
      continue;
    }
    for (auto& c : children_) {
      if (c.module != it->first || !c.running || c.term_at >= 0.0) continue;  // (one asked to stop: SIGKILL 5 s on)
      logf("tandem up: %s is still waiting after its module's task ended; stopping it\n", c.label.c_str());
      c.expected = true;
      terminate(c, now);
    }
    it = world_done_.erase(it);
  }
  // Said once: every process started so far has been heard (the deployment is up, as far as discovery goes).
  if (!all_heard_said_ && !stopping_) {
    int n = 0;
    bool all = true;
    for (const auto& c : children_) {
      if (!c.running || c.expected) continue;
      ++n;
      all = all && c.heard && !c.cut_off;
    }
    if (all && n > 0) {
      logf("tandem up: all %d process(es) heard on the domain\n", n);
      all_heard_said_ = true;
    }
  }
  // A process whose status was never heard within kSilentStartS of its start runs cut off from the domain (seen in
  // soaks: now and then a participant started beside many others never matched anyone): it is killed, and its
  // restart policy applies as for any failure.
  for (auto& c : children_) {
    if (!c.running || c.heard || c.expected || stopping_ || c.role == "discovery") continue;
    if (now - c.started > kSilentStartS) {
      logf("tandem up: %s (pid %d) was not heard on the domain within %.0f s of its start; SIGKILL, its "
           "restart policy applies\n", c.label.c_str(), c.pid, kSilentStartS);
      signal_child(c, SIGKILL, now);
      c.heard = true;  // once
      c.cut_off = true;
    }
  }
  // A module that has not come up in time (start_timeout): some pair of its participants never matched.
  if (!stopping_) {
    for (auto& [name, mr] : modules_) {
      if (!mr.started || mr.ticked || !mr.end.running() || mr.repairs >= kStartRepairs) continue;
      // (A world waits up to half its timeout for late sensor readers besides the first, and in real time its
      // first tick up to 5 s more for the robots' first commands, world::StartWait: not cut short.)
      const double limit = std::max(cfg_.start_timeout, 0.5 * cfg_.timeout + 2.0) + (cfg_.realtime ? 5.0 : 0.0);
      if (now - mr.started_at < limit) continue;
      char why[96];
      std::snprintf(why, sizeof why, "its world did not tick within %.1f s of its start", limit);
      repair_start(name, why, now);
    }
  }
  // A process asked to stop alone that is still there after 5 s (hung, or stopped by a signal).
  for (auto& c : children_) {
    if (c.running && c.term_at >= 0.0 && now - c.term_at > 5.0) {
      logf("tandem up: %s did not stop within 5 s of SIGTERM; sending SIGKILL\n", c.label.c_str());
      signal_child(c, SIGKILL, now);
      c.term_at = -1.0;
    }
  }
  run_pending_restarts(now);
}

void Supervisor::run_pending_restarts(double now) {
  for (auto it = pending_restarts_.begin(); it != pending_restarts_.end();) {
    if (!it->child.module.empty() && modules_.at(it->child.module).task_over) {  // at once, not when due
      logf("tandem up: not restarting %s: module %s is done with its task\n", it->child.label.c_str(),
           it->child.module.c_str());
      it = pending_restarts_.erase(it);
      continue;
    }
    if (stopping_ || now < it->when) {
      ++it;
      continue;
    }
    const Child c = it->child;
    it = pending_restarts_.erase(it);
    const std::optional<Role> role = parse_role(c.role);
    if (role) {  // (starting does not touch pending_restarts_: `it` stays valid)
      DueRestart f;
      f.role = *role;
      f.strength = c.strength;
      f.restart_as_standby = !c.module.empty() && modules_.at(c.module).spec.restart_as_standby;
      f.primary_alive = c.role == "robot" && primary_of(c.arm) != nullptr;
      f.standby_strength = c.arm.empty() ? 0 : standby_strength(c.arm);
      f.live_in_slot = c.arm.empty() ? 0 : live_robots(c.arm);
      f.task_over = !c.module.empty() && modules_.at(c.module).task_over;
      const DueRestartDecision d = due_restart(f);
      if (!d.start) {
        logf("tandem up: not restarting %s: %s\n", c.label.c_str(), d.why.c_str());
      } else if (c.role == "robot") {
        start_robot(c.module, c.arm.substr(c.arm.find('/') + 1), d.strength, " (restart)", now);
      } else if (c.role == "supervisor") {
        start_supervisor(c.module, d.strength, " (restart)", now);  // a standby: it adopts the serving one's plan
      } else {
        // No coordinator left: the queue's state lived only in their writers (transient-local), so hand the
        // newcomer the last state this launcher heard; it takes over from it.
        if (live_coordinators() == 0 && have_coord_state_) {
          out_.republish_coordinator_state();
          logf("tandem up: republished the coordinator's last state (%zu task(s) done) for its successor\n",
               coord_done_);
        }
        start_coordinator("coordinator@r" + std::to_string(++coordinator_restarts_), true, " (restart)", now);
      }
    }
  }
}

void Supervisor::handle_exit(Child& c, double now) {
  if (c.status >= 128) {  // killed: its shared-memory files are left behind (cleaned by the caller)
    shm_dirty_ = true;
    killed_at_ = now;
  }
  const std::optional<Role> role = parse_role(c.role);
  if (!role) return;  // not a role the launcher supervises (never started as such)
  ExitFacts f;
  f.role = *role;
  f.status = c.status;
  f.expected = c.expected;
  f.never_heard = c.cut_off;
  f.stopping = stopping_;
  f.coordinated = cfg_.coordinated;
  f.max_repairs = kStartRepairs;
  ModuleRun* mr = c.module.empty() ? nullptr : &modules_.at(c.module);
  if (mr != nullptr) {
    f.module_ticked = mr->ticked;
    f.module_repairs = mr->repairs;
    f.module_draining = mr->end.is(ModuleEnd::Kind::Draining);
    f.restart_always = mr->spec.restart.policy == "always";
  }
  f.live_peers = *role == Role::Coordinator ? live_coordinators() : live_robots(c.arm);
  f.peer_leads = *role == Role::Supervisor && leader_of(c.arm, &c) != nullptr;
  const std::string code = std::to_string(c.status);
  switch (launcher::on_exit(f)) {
    case ExitVerdict::Nothing:
      return;
    case ExitVerdict::AllTasksDone:
      logf("tandem up: %s reports every task done; stopping the deployment\n", c.label.c_str());
      coordinator_done_ = true;
      stop_all(SIGTERM, now);
      return;
    case ExitVerdict::Restart:
      break;
    case ExitVerdict::RepairStart:
      repair_start(c.module,
                   c.label + (c.cut_off ? " was never heard on the domain" : " exited with code " + code) +
                       " before the first tick: its peers did not match",
                   now);
      return;
    case ExitVerdict::Drained:
      logf("tandem up: module %s drained; stopping its processes\n", c.module.c_str());
      mr->end = ModuleEnd::of(ModuleEnd::Kind::Unplugged);
      if (governor_) governor_->set_available(c.module, false);
      stop_module(c.module, now);
      return;
    case ExitVerdict::ModuleLostPlan:
      // No leader and no replica has the module's plan (its leader died before a standby heard it). Tier 3: the
      // module restarts from its initial grasp with new processes; the coordinator re-plans its task meanwhile.
      logf("tandem up: module %s lost its plan (%s had no leader to follow); restarting the module\n",
           c.module.c_str(), c.label.c_str());
      ++plan_restarts_;
      mr->end = ModuleEnd::of(ModuleEnd::Kind::Repairing);
      stop_module(c.module, now);
      pending_clears_.push_back(c.module);
      return;
    case ExitVerdict::TaskOver:
      // The module's task is over. Its processes end by themselves, but for one that joined late (a restarted
      // standby) and waits for ticks that will not come: stopped after a grace for the summaries.
      if (*role == Role::World) {
        world_done_[c.module] = now;
        mr->task_over = true;
      }
      return;
    case ExitVerdict::ModuleFailed:
      // (Not a module failed by a drop: it stays out until cleared, whatever ends its world. Nor a draining one: its
      // unplug stands, and it ends failed rather than come back as if never unplugged.)
      if (*role == Role::World && c.spun && mr->end.running() && mr->spin_repairs < kSpinRepairs &&
          task_state(c.module) != static_cast<int>(plan::TaskStateCode::Failed)) {
        ++mr->spin_repairs;
        logf("tandem up: module %s's world was killed for a spinning thread (no physical event); restarting the "
             "module from its initial grasp (%d of at most %d), its task is re-planned\n",
             c.module.c_str(), mr->spin_repairs, kSpinRepairs);
        mr->end = ModuleEnd::of(ModuleEnd::Kind::Repairing);
        stop_module(c.module, now);
        pending_clears_.push_back(c.module);
        return;
      }
      logf("tandem up: module %s failed (%s exited with code %d); stopping its processes, the others go on\n",
           c.module.c_str(), c.label.c_str(), c.status);
      mr->end = ModuleEnd::of(ModuleEnd::Kind::Failed, c.label + " exited with code " + code);
      if (governor_) governor_->set_available(c.module, false);
      stop_module(c.module, now);
      return;
    case ExitVerdict::Fail:
      fail(c.label + " exited with code " + code, now);
      return;
  }
  // Restart: by the policy of its slot, then whether the slot is still served.
  const bool restarting = schedule_restart(c, mr == nullptr ? cfg_.coordinator_restart : mr->spec.restart, now);
  f.live_peers = *role == Role::Coordinator ? live_coordinators() : live_robots(c.arm);
  const AfterRestart next = after_restart(f, restarting);
  switch (*role) {
    case Role::Coordinator:
      if (next == AfterRestart::Fail) {
        fail(c.label + " exited with code " + code + " and no coordinator is left", now);
        return;
      }
      logf("tandem up: %s exited with code %d; %s\n", c.label.c_str(), c.status,
           f.live_peers > 0 ? "a standby coordinator carries on" : "a new coordinator will take over");
      return;
    case Role::Supervisor:
      if (c.status == exit_code::kLostPlan && f.peer_leads) {
        logf("tandem up: %s had no plan to follow, but %s leads module %s: it was deaf to its leader%s\n",
             c.label.c_str(), leader_of(c.arm, &c)->label.c_str(), c.module.c_str(),
             restarting ? " (it comes back as a standby, with a fresh participant)" : "");
        return;
      }
      logf("tandem up: %s exited with code %d; a standby supervisor carries on%s\n", c.label.c_str(), c.status,
           restarting ? " (the exited one comes back as a standby)" : "");
      return;
    case Role::Robot:
    case Role::World:
      break;
  }
  switch (next) {
    case AfterRestart::CarriesOn:
      logf("tandem up: %s exited with code %d; another robot serves its arm, the deployment goes on\n",
           c.label.c_str(), c.status);
      return;
    case AfterRestart::WaitsForRestart:
      logf("tandem up: %s exited with code %d; its arm is braked until the restarted robot answers\n", c.label.c_str(),
           c.status);
      return;
    case AfterRestart::WaitsForPlug:
      logf("tandem up: %s exited with code %d and nobody serves %s: the module stays paused with the "
           "arm braked; plug a robot in ('tandem plug robot %s') to resume\n",
           c.label.c_str(), c.status, c.arm.c_str(), c.arm.c_str());
      return;
    case AfterRestart::Fail:
      fail(c.label + " exited with code " + code, now);
      return;
  }
}

/// Restart policy (OTP-style, RestartPolicy): returns true if `c` will be started again after the backoff.
bool Supervisor::schedule_restart(const Child& c, const RestartRule& rule, double now) {
  const std::string key = c.arm.empty() ? "coordinator" : c.arm;  // an arm, a module's supervisor slot
  const RestartDecision d = restarts_.on_exit(key, c.status, rule, now);
  if (d.kind == RestartDecision::Kind::None) return false;
  if (d.kind == RestartDecision::Kind::GiveUp) {
    logf("tandem up: giving up on %s: %d restarts within %.0f s (restart_limit %d)\n", key.c_str(), d.count,
         rule.window, rule.limit);
    return false;
  }
  logf("tandem up: restarting %s in %.2f s (restart %d of at most %d within %.0f s)\n", c.label.c_str(), d.delay,
       d.count, rule.limit, rule.window);
  pending_restarts_.push_back({now + d.delay, c});
  return true;
}

/// A module that did not come up: a process gave up waiting for its peers (world 3: peers not found; world, robot
/// or supervisor 4: no tick, input or report), or was never heard, before the world's first tick, or its world did
/// not tick within start_timeout. With DDS-Security a pair of participants sometimes never authenticates (a race in
/// Fast DDS 2.9.1's SecurityManager, fixed in 2.9.2; docs/security.md), and nothing in the library retries it; new
/// participants for the whole module (new GUIDs, fresh handshakes with everyone) repair it. Restarted up to
/// kStartRepairs times, logged and counted.
void Supervisor::repair_start(const std::string& module, const std::string& why, double now) {
  ModuleRun& mr = modules_.at(module);
  ++mr.repairs;
  ++start_repairs_;
  logf("tandem up: module %s did not come up (%s); restarting the module with new participants (repair %d "
       "of at most %d)\n", module.c_str(), why.c_str(), mr.repairs, kStartRepairs);
  mr.end = ModuleEnd::of(ModuleEnd::Kind::Repairing);
  stop_module(module, now);
  pending_clears_.push_back(module);
}

void Supervisor::stop_module(const std::string& module, double now) {
  for (auto& c : children_) {
    if (c.module != module) continue;
    c.expected = true;
    if (c.running) terminate(c, now);
  }
  pending_unplugs_.erase(std::remove_if(pending_unplugs_.begin(), pending_unplugs_.end(),
                                        [&](const auto& u) { return u.module == module; }),
                         pending_unplugs_.end());
  // Restarts still pending for it are dropped (a module plugged in again starts afresh).
  const size_t before = pending_restarts_.size();
  pending_restarts_.erase(std::remove_if(pending_restarts_.begin(), pending_restarts_.end(),
                                         [&](const auto& r) { return r.child.module == module; }),
                          pending_restarts_.end());
  if (pending_restarts_.size() != before) {
    logf("tandem up: %zu pending restart(s) of module %s dropped: it was stopped\n", before - pending_restarts_.size(),
         module.c_str());
  }
}

void Supervisor::fail(const std::string& why, double now) {
  errf("tandem up: %s; stopping the deployment\n", why.c_str());
  failed_ = true;
  stop_all(SIGTERM, now);
}

/// Asks one process to stop (SIGTERM); poll() sends SIGKILL if it is still there 5 s later.
void Supervisor::terminate(Child& c, double now) {
  if (!c.running || (c.pid <= 0 && c.host.empty())) return;
  signal_child(c, SIGTERM, now);
  if (c.term_at < 0.0) c.term_at = now;
}

void Supervisor::stop_all(int sig, double now) {
  if (!stopping_) stop_started_ = now;
  stopping_ = true;
  for (auto& c : children_) {
    if (c.running && (c.pid > 0 || !c.host.empty())) signal_child(c, sig, now);
  }
}

void Supervisor::escalate(double now) {
  if (stopping_ && !escalated_ && now - stop_started_ > 5.0) {
    logf("tandem up: %d process(es) did not stop within 5 s; sending SIGKILL\n", running());
    stop_all(SIGKILL, now);
    escalated_ = true;
  }
}

/// Sends `sig` to a child: here by pid, on another host through its agent (re-sent until it is reported gone).
void Supervisor::signal_child(Child& c, int sig, double now) {
  if (c.host.empty()) {
    if (c.pid > 0) exec_.signal(c, sig);
    return;
  }
  if (hosts_ != nullptr && hosts_->lost(c.host)) return;  // counted as gone already
  if (c.signal != SIGKILL) c.signal = sig;  // re-sent by watch_hosts until the agent reports it gone
  exec_.signal(c, c.signal);
  c.signal_sent = now;
}

/// A child is gone: exited with `status` (128 + signal if killed), or counted as failed (its host was lost).
void Supervisor::mark_exited(Child& c, int status) {
  c.running = false;
  c.status = status;
  if (c.participant_id >= 0) free_ids_.push_back(c.participant_id);  // reused last
  c.participant_id = -1;
}

// ---- shedding whole modules (Governor, docs/failure-model.md) ---------------------------------------------------

void Supervisor::govern(double now) {
  if (!governor_ || stopping_) return;
  const Governor::Decision dec = governor_->decide(now);
  if (dec.kind == Governor::Decision::Kind::Park) {
    logf("tandem up: parking module %s (%s): its processes stop once it is paused; its task goes back to "
         "the queue\n", dec.module.c_str(), dec.why.c_str());
    modules_.at(dec.module).end = ModuleEnd::of(ModuleEnd::Kind::Parked, dec.why);
    ++parks_;
    send(dec.module, ModuleCommand::Pause);
    pending_parks_.push_back({dec.module, now});
  } else if (dec.kind == Governor::Decision::Kind::Unpark) {
    logf("tandem up: unparking module %s (%s)\n", dec.module.c_str(), dec.why.c_str());
    pending_unparks_.push_back(dec.module);
  }
  // Parks: stop once the module reports paused (object at rest), or after 2 s (the brakes hold it).
  for (auto it = pending_parks_.begin(); it != pending_parks_.end();) {
    const bool paused = task_state(it->module) == code(plan::TaskStateCode::Paused);
    if (!paused && now - it->since < 2.0) {
      ++it;
      continue;
    }
    stop_module(it->module, now);
    task_states_.erase(it->module);
    logf("tandem up: module %s parked%s\n", it->module.c_str(), paused ? " (paused first)" : " (not paused within 2 s)");
    it = pending_parks_.erase(it);
  }
  // Unparks: once every process of the module is gone.
  for (auto it = pending_unparks_.begin(); it != pending_unparks_.end();) {
    if (!module_gone(*it)) {
      ++it;
      continue;
    }
    start_module(*it, now);
    it = pending_unparks_.erase(it);
  }
}

// ---- drains -------------------------------------------------------------------------------------------------------

/// A leader that has not acknowledged a drain sent every second for kDeafLeader does not hear the launcher: seen in
/// a soak-small hour, a restarted supervisor that took the lead never heard the drain (nor the coordinator's next
/// task) while its standby logged "drain requested"; the module then idled until the drain bound stopped it. Such
/// a leader is stopped when another supervisor of the module runs: that one takes over with the drain it heard and
/// finishes the task properly.
void Supervisor::stop_deaf_leader(const std::string& module, ModuleRun& mr, double now) {
  Child* leader = nullptr;
  bool other = false;
  for (auto& c : children_) {
    if (!c.running || c.role != "supervisor" || c.module != module) continue;
    if (c.leads && leader == nullptr) {
      leader = &c;
    } else {
      other = true;
    }
  }
  if (leader == nullptr || !other) return;
  mr.drain.leader_stopped();
  ++deaf_leaders_;
  logf("tandem up: %s leads module %s but has not acknowledged its drain for %.0f s (it does not hear the "
       "launcher); stopping it, a standby supervisor that heard the drain takes over\n",
       leader->label.c_str(), module.c_str(), DrainWatch::kDeafLeader);
  leader->expected = true;  // not restarted: the module is leaving
  terminate(*leader, now);
}

/// A drain the module's leading supervisor has not acknowledged (its task state neither draining nor left) is sent
/// again every second: found by the soak, a leader whose control reader missed the one request kept taking tasks,
/// and the module never left (its plug-in retries gave up after 60 s). The bounds are DrainWatch's: past
/// kDeafLeader the leader is taken for deaf (stop_deaf_leader); past kTimeout the module is stopped.
void Supervisor::resend_drains(double now) {
  for (auto& [name, mr] : modules_) {
    if (!mr.end.is(ModuleEnd::Kind::Draining)) continue;
    const bool load_paused = mr.load_paused_since >= 0.0 && now - mr.load_paused_since >= DrainWatch::kPausedForLoad;
    if (load_paused || mr.paused_for_unplug) {
      // Its task cannot end while the module is paused for load or for an arm whose only robot was unplugged, and its
      // processes load the machine the others share (the governor no longer counts a module that leaves): the CI
      // soak saw a module drain for the whole 30 s bound, paused, while the other module paused for load again and
      // again beside it (finding 78); a real-time hour saw one paused for an unplugged robot drain 30 s while the
      // other module was parked, and no task was done for 73 s (its robot's plug was refused: the module was leaving).
      if (load_paused) {
        logf("tandem up: module %s is paused for load while it drains (for %.1f s): its task cannot end soon; "
             "stopping it now (its brakes hold the object), its task goes back to the queue\n", name.c_str(),
             now - mr.load_paused_since);
      } else {
        logf("tandem up: module %s is paused for an unplugged robot while it drains: its task cannot end; stopping it "
             "now (its brakes hold the object), its task goes back to the queue\n", name.c_str());
      }
      mr.paused_for_unplug = false;
      ++forced_drains_;
      mr.end = ModuleEnd::of(ModuleEnd::Kind::Unplugged);
      stop_module(name, now);
      continue;
    }
    const int ts = task_state(name);
    const bool acked = ts == code(plan::TaskStateCode::Draining) || ts == code(plan::TaskStateCode::Left);
    const DrainStep step = mr.drain.step(now, acked);
    if (step.force) {
      const std::string last =
          ts == kTaskNone ? std::string("no task state heard")
                          : std::string("its task state: ") + plan::task_state_name(static_cast<uint8_t>(ts));
      logf("tandem up: module %s did not drain within %.0f s (%s); stopping it with its task unfinished, "
           "which goes back to the queue\n", name.c_str(), DrainWatch::kTimeout, last.c_str());
      ++forced_drains_;
      mr.end = ModuleEnd::of(ModuleEnd::Kind::Unplugged);
      stop_module(name, now);
      continue;
    }
    if (step.stop_leader) stop_deaf_leader(name, mr, now);
    if (step.warn) {
      logf("tandem up: module %s has not acknowledged its drain within %.0f s; still asking\n", name.c_str(),
           DrainWatch::kWarnAfter);
    }
    if (step.resend) send(name, ModuleCommand::Drain);
  }
}

// ---- multi-host: the agents --------------------------------------------------------------------------------------

std::vector<std::string> Supervisor::agents_not_serving() const {
  std::vector<std::string> out;
  for (const auto& h : cfg_.hosts) {
    const auto it = agent_runs_.find(h);
    if (it == agent_runs_.end() || it->second != cfg_.run) out.push_back(h);
  }
  return out;
}

void Supervisor::heartbeat(bool end) {
  if (hosts_ == nullptr) return;
  for (const auto& h : cfg_.hosts) exec_.heartbeat(h, hosts_->lost(h), end);
}

void Supervisor::restart_host_clock(double now) {
  if (hosts_) hosts_->restart_clock(now);
}

void Supervisor::on_agent_state(const AgentReport& st, double now) {
  if (hosts_ == nullptr || !hosts_->known(st.host)) return;
  agent_runs_[st.host] = st.run;
  if (st.run != cfg_.run && st.run != 0) {
    if (other_runs_.insert(st.host + "/" + std::to_string(st.run)).second) {
      logf("tandem up: the agent of %s serves another launcher run (%llu): is another `tandem up` of %s "
           "running? It will not start this run's processes while that one lives\n",
           st.host.c_str(), st.run, cfg_.deployment.c_str());
    }
    return;
  }
  // Which agent pids answer for the host, and when each was last heard: a process belongs to the agent that
  // reported it, and counts as failed when that agent falls silent (a restarted agent: its processes died with it)
  // even while the host is heard through another pid. Two pids heard at once: two agents for one host (the newer
  // leaves by itself).
  auto& pids = agent_heard_[st.host];
  pids[st.pid] = now;
  for (const auto& [other, at] : pids) {
    if (other != st.pid && now - at < 0.5 && two_agents_.insert(st.host).second) {
      logf("tandem up: two agents answer for host %s (pids %lld and %lld): one agent per host\n", st.host.c_str(),
           other, st.pid);
    }
  }
  if (hosts_->heard(st.host, now)) {
    logf("tandem up: host %s is back (its agent is heard again); its processes were replaced meanwhile\n",
         st.host.c_str());
  }
  if (st.run != cfg_.run) return;  // it has not had a request of this run yet
  std::set<unsigned long long> listed;
  for (const auto& ac : st.children) {
    listed.insert(ac.spawn_id);
    Child* c = nullptr;
    for (auto& x : children_) {
      if (x.spawn_id == ac.spawn_id && x.host == st.host) c = &x;
    }
    if (c == nullptr || !c->running) {
      // A process this launcher counts as gone (its host was lost meanwhile): fenced off, so that two robots never
      // command one arm as primaries.
      if (ac.running && fenced_.insert(ac.spawn_id).second) {
        logf("tandem up: %s on %s still runs but was counted as failed; SIGKILL\n", ac.label.c_str(),
             st.host.c_str());
        exec_.signal_spawn(st.host, ac.spawn_id, ac.label, SIGKILL);
      }
      continue;
    }
    if (!c->acked) {
      c->acked = true;
      c->agent_pid = st.pid;
      c->pid = static_cast<int>(ac.pid);
      if (ac.pid > 0) logf("  %-30s runs on %s as pid %lld\n", c->label.c_str(), c->host.c_str(), ac.pid);
    }
    if (!ac.running) {
      if (ac.pid <= 0) {
        logf("tandem up: the agent of %s could not start %s: %s\n", st.host.c_str(), c->label.c_str(),
             st.detail.c_str());
      }
      mark_exited(*c, ac.status);
      if (c->status >= 128) {
        shm_dirty_ = true;
        killed_at_ = now;
      }
    }
  }
  // A process the agent acknowledged and no longer lists (it forgot this run: restarted with the same pid?).
  for (auto& c : children_) {
    if (c.running && c.acked && c.host == st.host && c.agent_pid == st.pid && listed.count(c.spawn_id) == 0) {
      logf("tandem up: the agent of %s no longer reports %s; counted as failed\n", st.host.c_str(), c.label.c_str());
      mark_exited(c, 128 + SIGKILL);
    }
  }
}

/// Hosts whose agent fell silent: their processes count as failed (standbys elsewhere take over, a module without
/// its world is re-planned). Start requests not yet answered are re-sent.
void Supervisor::watch_hosts(double now) {
  if (hosts_ == nullptr) return;
  for (const auto& h : hosts_->newly_lost(now)) {
    std::string labels;
    int n = 0;
    for (auto& c : children_) {
      if (!c.running || c.host != h) continue;
      labels += (labels.empty() ? "" : ", ") + c.label;
      ++n;
      mark_exited(c, 128 + SIGKILL);
    }
    logf("tandem up: host %s lost: no word from its agent for %.1f s; its %d process(es) count as failed%s%s\n",
         h.c_str(), cfg_.host_timeout, n, n > 0 ? ": " : "", labels.c_str());
  }
  // Processes whose agent fell silent while its host is still heard (through a new agent: a restart).
  for (auto& c : children_) {
    if (!c.running || c.host.empty() || !c.acked || hosts_->lost(c.host)) continue;
    const auto& pids = agent_heard_[c.host];
    const auto it = pids.find(c.agent_pid);
    if (it != pids.end() && now - it->second > cfg_.host_timeout) {
      logf("tandem up: the agent of %s that ran %s (pid %lld) is gone (another agent answers for the host); "
           "counted as failed\n", c.host.c_str(), c.label.c_str(), c.agent_pid);
      mark_exited(c, 128 + SIGKILL);
    }
  }
  for (auto& c : children_) {
    if (!c.running || c.host.empty() || c.acked) continue;
    if (now - c.started > 10.0) {
      logf("tandem up: the agent of %s did not start %s within 10 s; counted as failed to start\n", c.host.c_str(),
           c.label.c_str());
      mark_exited(c, 127);
    } else if (now - c.sent > 0.2) {
      (void)exec_.start(c);
      c.sent = now;
    }
  }
  // Signals are re-sent until the agent reports the process gone (the request topic keeps the newest 32 per host: a
  // burst to many processes of one host could lose some).
  for (auto& c : children_) {
    if (c.running && !c.host.empty() && c.signal != 0 && now - c.signal_sent > 0.2) {
      exec_.signal(c, c.signal);
      c.signal_sent = now;
    }
  }
}

}  // namespace tandem::launcher
