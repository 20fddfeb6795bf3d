// One run of `tandem up`: see up_run.hpp. The supervision itself is launcher::Supervisor (services/launcher: events
// in, actions out); this file wires it to DDS, to the processes and to the clock.
#include "up_run.hpp"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <map>
#include <thread>
#include <utility>

#include "tandem/launcher/spawn.hpp"
#include "tandem/runtime/role.hpp"
#include "tandem/runtime/shm_clean.hpp"

namespace tandem::cli::up {

UpRun::RemoveFile::~RemoveFile() {
  if (!path.empty()) ::unlink(path.c_str());
}

UpRun::UpRun(Deployment d, UpOptions o, std::vector<launcher::ModuleSpec> specs, std::atomic<bool>& stop)
    : stop_(stop),
      d_(std::move(d)),
      o_(std::move(o)),
      lines_(d_, o_.file),
      local_(lines_),
      run_id_(new_run()),
      agents_(lines_, d_.name, run_id_),
      outbox_(d_.name, lines_),
      L_(supervisor_config(d_, o_.file, run_id_), d_.hosts.empty() ? static_cast<launcher::Executor&>(local_) : agents_,
         outbox_),
      view_(d_.name) {
  for (auto& s : specs) L_.add_module(std::move(s));
  if (d_.hosts.empty()) {  // one host: the port files of the ids it hands out are on this machine (soak finding 59)
    const int domain = static_cast<int>(d_.domain_id);
    L_.set_participant_id_check([domain](int id) { return runtime::participant_port_files_exist(domain, id); });
  }
}

int UpRun::run() {
  if (const int code = prepare(); code >= 0) return code;
  if (!join_domain()) return 2;
  if (!d_.hosts.empty() && !wait_for_agents()) return 2;
  std::printf("tandem up %s: %zu module(s), domain %d, %s, %s timing%s%s\n", d_.name.c_str(), d_.modules.size(),
              d_.domain_id, d_.transport.c_str(), d_.timing.c_str(),
              lines_.rt_priority_ > 0 ? (", SCHED_FIFO " + std::to_string(lines_.rt_priority_)).c_str() : "",
              lines_.pins_modules() ? ", each module's world and robots on one CPU" : "");
  capacity_ = launcher::capacity_estimate(load_of(d_));
  if (capacity_.realtime) {  // the calibrated estimate, or its warning (tandem soak waits for this line)
    std::printf("tandem up: %s\n", capacity_.text.c_str());
    std::fflush(stdout);
  }
  if (!start_recorder()) return 2;
  start_viewer();
  L_.restart_host_clock(now_s());  // the recorder was awaited without reading agent states
  start_modules();
  t0_ = last_print_ = launcher_published_ = heartbeat_sent_ = Clock::now();
  outbox_.last_coord_ = &heard_.last_coord;
  while (L_.busy()) {
    step();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return finish();
}

int UpRun::prepare() {
  // DDS-Security: every identity's files are there and valid before anything starts; the launcher joins as
  // "launcher", its children inherit the keys' directory and get their slot's identity (CommandLines::identity).
  if (!d_.security_keys.empty()) {
    const std::string err = runtime::check_keys(d_);
    if (!err.empty()) {
      std::fprintf(stderr, "tandem up: %s\n", err.c_str());
      return 2;
    }
    (void)runtime::use_security(d_, "launcher");
  }
  if (o_.check_only) {
    std::printf("tandem up: %s is valid: %zu module(s), domain %d, %s timing\n%s\n", o_.file.c_str(), d_.modules.size(),
                d_.domain_id, d_.timing.c_str(), launcher::capacity_estimate(load_of(d_)).text.c_str());
    return 0;
  }
  // Real time: the per-tick processes raise themselves to SCHED_FIFO once active; the launcher and everything it
  // starts run at kServiceNice meanwhile (before any thread or child exists, so that all inherit it).
  if (d_.timing == "realtime" && d_.realtime_priority > 0) {
    std::string why;
    if (launcher::fifo_permitted(d_.realtime_priority, why)) {
      lines_.rt_priority_ = d_.realtime_priority;
      (void)launcher::raise_service_priority(why);  // permitted wherever SCHED_FIFO is
    } else {
      std::printf("tandem up: note: real-time priority %d not permitted here (%s); the per-tick processes run "
                  "with normal scheduling and may miss more ticks (run as root, or grant CAP_SYS_NICE or an "
                  "RLIMIT_RTPRIO; 'realtime_priority: 0' silences this)\n",
                  d_.realtime_priority, why.c_str());
    }
  } else if (d_.timing == "lockstep") {
    // Lockstep keeps both cores busy with per-tick work: the control plane (this launcher, supervisors,
    // coordinators, processes starting) runs at kServiceNice ahead of it; the world and robots go to niceness 0
    // once active (runtime::raise_to_realtime_from_env). Where not permitted, everything runs at one priority.
    // This process's own scheduling group keeps its nice value: the per-tick processes stay in it.
    std::string why;
    (void)launcher::raise_service_priority(why, false);
  }
  return -1;
}

bool UpRun::join_domain() {
  // discovery: server. The launcher starts the Discovery Server first (a child like the others: it dies with
  // the launcher) and makes itself and every process it starts a client of it.
  launcher_started_ = std::time(nullptr) - 1;
  sweeper_.emplace(launcher_started_, -1);
  const bool started = start_discovery(d_, discovery_servers_, discovery_profile_);
  for (const pid_t pid : discovery_servers_) server_stops_.emplace_back(pid, 1.0);  // stopped even if one failed
  if (!started) return false;
  // Over UDP only, whatever the deployment's transport: nothing another process does can wedge the launcher's
  // receiving. Over shared memory a killed sender can leave a buffer in the launcher's port that names a segment that
  // no longer exists, and Fast DDS 2.9's listener then retries it for ever (eProsima/Fast-DDS#2398, #5732): the
  // lockstep soak hour saw the launcher hear no process started after 1216 s, kill each for it, and the deployment
  // wear away (docs/soak.md finding 50). Its traffic (status, summaries, requests) is small.
  try {
    part_ = std::make_unique<bus::Participant>(d_.domain_id, "launcher/" + d_.name, bus::Transport::Udp);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem up: %s\n", e.what());
    return false;
  }
  bus::Participant& part = *part_;
  robot_sum_ = std::make_unique<bus::Reader<msg::RobotSummary, msg::RobotSummaryPubSubType>>(part, bus::kRobotSummaryTopic,
                                                                                            bus::TopicKind::Summary);
  world_sum_ = std::make_unique<bus::Reader<msg::WorldSummary, msg::WorldSummaryPubSubType>>(part, bus::kWorldSummaryTopic,
                                                                                            bus::TopicKind::Summary);
  status_ = std::make_unique<bus::Reader<msg::ProcessStatus, msg::ProcessStatusPubSubType>>(part, bus::kStatusTopic,
                                                                                           bus::TopicKind::Status);
  control_ = std::make_unique<bus::Reader<msg::ControlRequest, msg::ControlRequestPubSubType>>(part, bus::kControlTopic,
                                                                                              bus::TopicKind::Control);
  control_out_ = std::make_unique<bus::Writer<msg::ControlRequest, msg::ControlRequestPubSubType>>(part, bus::kControlTopic,
                                                                                                  bus::TopicKind::Control);
  task_states_ = std::make_unique<bus::Reader<msg::TaskState, msg::TaskStatePubSubType>>(part, bus::kTaskStateTopic,
                                                                                         bus::TopicKind::Task);
  coord_state_ = std::make_unique<bus::Reader<msg::CoordinatorState, msg::CoordinatorStatePubSubType>>(
      part, bus::kCoordinatorStateTopic, bus::TopicKind::Task);
  outbox_.control_out_ = control_out_.get();
  coord_state_out_ = std::make_unique<bus::Writer<msg::CoordinatorState, msg::CoordinatorStatePubSubType>>(
      part, bus::kCoordinatorStateTopic, bus::TopicKind::Task);
  outbox_.coord_state_out_ = coord_state_out_.get();
  // Multi-host: the agents (docs/multihost.md). Every host's agent is heard before anything starts.
  if (!d_.hosts.empty()) {
    agent_out_ = std::make_unique<bus::Writer<msg::AgentRequest, msg::AgentRequestPubSubType>>(part, bus::kAgentRequestTopic,
                                                                                               bus::TopicKind::Control);
    agent_state_ = std::make_unique<bus::Reader<msg::AgentState, msg::AgentStatePubSubType>>(part, bus::kAgentStateTopic,
                                                                                             bus::TopicKind::Status);
    agents_.out_ = agent_out_.get();
  }
  launcher_status_ = std::make_unique<runtime::StatusPublisher>(part, "launcher", "launcher", "");
  launcher_status_->msg().deployment(d_.name);
  launcher_status_->set(runtime::Lifecycle::Active, "");
  return true;
}

bool UpRun::wait_for_agents() {
  const auto asked = Clock::now();
  auto last_note = asked - std::chrono::seconds(10);
  while (!stop_) {
    msg::AgentState st;
    while (agent_state_->take(st)) {
      if (st.deployment() == d_.name) L_.on_agent_state(report_of(st), now_s());
    }
    // Every agent heard, and serving this run: its state says so once it has this launcher's heartbeat, so the
    // requests reach it both ways (a state heard alone once came with requests that never arrived).
    const auto waiting = L_.agents_not_serving();
    if (waiting.empty()) break;
    std::string list;
    for (const auto& h : waiting) list += (list.empty() ? "" : ", ") + h;
    // As long as a process waits for its peers (timeout:), at least 5 s.
    const double wait_s = std::max(5.0, d_.timeout);
    if (Clock::now() - asked > std::chrono::duration<double>(wait_s)) {
      std::fprintf(stderr, "tandem up: no agent serving this run within %.0f s for host(s) %s; start `tandem agent %s "
                           "--host NAME` on each (same domain %d, discovery %s)\n",
                   wait_s, list.c_str(), o_.file.c_str(), d_.domain_id, runtime::discovery_text(d_).c_str());
      return false;
    }
    if (Clock::now() - last_note > std::chrono::seconds(3)) {
      std::printf("tandem up: waiting for the agents of %s\n", list.c_str());
      std::fflush(stdout);
      last_note = Clock::now();
    }
    launcher_status_->publish();
    L_.heartbeat();  // the agents learn which run they serve
    agent_state_->wait(0.1);
  }
  std::printf("tandem up: %zu host(s), every agent heard and serving this run\n", d_.hosts.size());
  return true;
}

bool UpRun::start_recorder() {
  // record: the recorder joins first and is heard before any module starts, so that it has every tick (the
  // worlds also wait for its readers in lockstep: --observers). It is stopped last, after the summaries.
  if (!d_.record.empty()) {
    std::vector<std::string> rargs{"record", o_.file, "-o", d_.record, "--attached"};
    if (!d_.record_topics.empty()) rargs.insert(rargs.end(), {"--topics", d_.record_topics});
    recorder_ = spawn(lines_.dir() + "/tandem", rargs, 0, -1, d_.security_keys.empty() ? "" : "recorder");
    if (recorder_ < 0) return false;
    std::printf("  started recorder             pid %d -> %s\n", recorder_, d_.record.c_str());
    bool heard = false;
    const auto asked = Clock::now();
    while (!heard && !stop_ && Clock::now() - asked < std::chrono::seconds(10)) {
      msg::ProcessStatus ps;
      while (status_->take(ps)) {
        view_.update(ps);
        heard = heard || (ps.process_id() == "recorder" && ps.pid() == recorder_ && ps.state() == 2);
      }
      L_.heartbeat();  // the agents' launcher lives meanwhile
      if (::waitpid(recorder_, nullptr, WNOHANG) == recorder_) {
        std::fprintf(stderr, "tandem up: the recorder exited at start (see its message above)\n");
        return false;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (!heard) std::printf("tandem up: note: the recorder was not heard within 10 s; starting anyway\n");
  }
  // Stopped last with SIGTERM: it closes the file (summary section, footer); SIGKILL after 30 s. An exit of its own
  // before that is a failed recording.
  recorder_stop_.emplace(recorder_, 30.0, "tandem up: the recorder did not close its file within 30 s; SIGKILL\n");
  return true;
}

void UpRun::start_viewer() {
  // --view: the live view (tandem view) beside the deployment, started before the modules and stopped after the
  // summaries; it prints its URL. Not supervised: a viewer that exits leaves the deployment alone.
  if (o_.with_view) {
    std::vector<std::string> vargs{"view", o_.file, "--port", o_.view_port.empty() ? "8765" : o_.view_port};
    // An observer at niceness 0 (it sets it itself): in the launcher's group, not a group of its own.
    viewer_ = spawn(lines_.dir() + "/tandem", vargs, 0, -1, d_.security_keys.empty() ? "" : "recorder", false);
    if (viewer_ > 0) std::printf("  started viewer               pid %d\n", viewer_);
  }
  viewer_stop_.emplace(viewer_, 5.0, "tandem up: the viewer did not stop within 5 s; SIGKILL\n");
}

void UpRun::start_modules() {
  std::set<std::string> start_parked;
  if (capacity_.realtime && d_.coordinator && d_.shed_modules && d_.overload_brake) {
    // Shedding whole modules (launcher::Governor), and admission: the modules the calibrated estimate fits,
    // in file order, start; the others start parked and come back when the machine has been calm.
    std::vector<std::pair<std::string, int>> autostart;
    for (const auto& m : d_.modules) {
      if (m.autostart) autostart.emplace_back(m.name, m.standby);
    }
    const launcher::Admission adm = launcher::admission(capacity_, autostart, !d_.hosts.empty());
    for (const std::string& m : L_.admit(adm.order, adm.fit, now_s())) start_parked.insert(m);
    if (!start_parked.empty()) {
      std::string list;
      for (const auto& m : start_parked) list += (list.empty() ? "" : ", ") + m;
      std::printf("tandem up: starting %s parked: the calibrated estimate gives %.3f core per module (with its "
                  "standbys) and %zu of %zu fit in %.2f usable cores; parked modules start when the machine has been "
                  "calm (docs/failure-model.md, \"Shedding whole modules\")\n",
                  list.c_str(), capacity_.of(d_.modules.front().standby), adm.fit, adm.order.size(), capacity_.usable);
    }
  }
  std::vector<std::string> starting;
  for (const auto& m : d_.modules) {
    if (m.autostart && !start_parked.count(m.name)) starting.push_back(m.name);
  }
  L_.start_modules(starting, now_s());
  if (L_.queued_starts() > 0) {
    std::printf("tandem up: modules start one by one (module_start: one_by_one): %zu wait for the one before to "
                "tick\n", L_.queued_starts());
  }
  L_.start_coordinators(now_s());
}

void UpRun::collect() {
  msg::RobotSummary rs;
  while (robot_sum_->take(rs)) heard_.robots[rs.robot_id()] = rs;
  msg::WorldSummary ws;
  while (world_sum_->take(ws)) heard_.worlds[ws.module_id()] = ws;
  msg::TaskState ts;
  while (task_states_->take(ts)) {
    if (ts.deployment() == d_.name) L_.on_task_state(ts.module_id(), ts.state());
  }
  msg::CoordinatorState cs;
  bool advanced = false;
  while (coord_state_->take(cs)) {
    if (cs.deployment() != d_.name) continue;
    const auto kept = L_.on_coordinator_state(cs.next_task_id(), cs.done_total(), done_in(cs));
    if (kept == launcher::Supervisor::QueueState::Older) continue;
    advanced = advanced || kept == launcher::Supervisor::QueueState::Advanced;
    heard_.last_coord = cs;
    heard_.have_coord = true;
  }
  // Mirrored (Supervisor::on_coordinator_state). Found by the hour-long soak: the primary died while its restarted
  // peer was still starting, both came back with --resume and no state, and no task was done again.
  if (advanced && d_.coordinator) coord_state_out_->write(heard_.last_coord);
}

void UpRun::publish_launcher_status() {
  // The launcher's status lists what it runs, so that `tandem status` knows whom to wait for.
  std::vector<std::string> labels;
  labels.reserve(L_.children().size());
  for (const auto& c : L_.children()) {
    if (c.running) labels.push_back(c.label);
  }
  // Also every 100 ms, like every other process: a late joiner that has matched hears the launcher within
  // 100 ms whatever its vendor's repair handshake (docs/interop.md).
  if (labels != running_labels_ || Clock::now() - launcher_published_ > std::chrono::milliseconds(100)) {
    running_labels_ = labels;
    launcher_status_->msg().runs(labels);
    launcher_status_->publish();
    launcher_published_ = Clock::now();
  }
}

void UpRun::serve_requests() {
  msg::ControlRequest req;
  while (control_->take(req)) {
    if (req.deployment() != d_.name) continue;
    const msg::ControlCommand cmd = req.command();
    if (cmd != msg::CMD_PAUSE && cmd != msg::CMD_RESUME && cmd != msg::CMD_DRAIN) {  // (the launcher's own)
      L_.on_request(request_of(req), now_s());
      if (L_.down_requested()) stop_ = true;
      std::fflush(stdout);
    }
    // The answer the sender waits for (again, for a request re-sent: see Supervisor::answer).
    if (const launcher::Supervisor::Answer* answer = L_.answer(req.seq())) {
      launcher_status_->msg().reply_seq(req.seq());
      launcher_status_->msg().reply_ok(answer->ok);
      launcher_status_->msg().reply_text(answer->text);
      launcher_status_->publish();
    }
  }
}

void UpRun::step() {
  if (agent_state_) {  // before poll(): a host is judged on the newest word from its agent
    msg::AgentState st;
    while (agent_state_->take(st)) {
      if (st.deployment() == d_.name) L_.on_agent_state(report_of(st), now_s());
    }
    if (Clock::now() - heartbeat_sent_ >= std::chrono::milliseconds(100)) {
      L_.heartbeat();
      heartbeat_sent_ = Clock::now();
    }
  }
  reap_local(L_);
  L_.poll(now_s());
  L_.govern(now_s());
  L_.escalate(now_s());
  publish_launcher_status();
  collect();
  msg::ProcessStatus ps;
  while (status_->take(ps)) {
    view_.update(ps);
    const Child* first_active =
        L_.on_status(ps.process_id(), ps.pid(), ps.state() == static_cast<uint8_t>(runtime::Lifecycle::Active),
                     ps.serving() != msg::ROLE_NONE, ps.serving() == msg::ROLE_PRIMARY);
    if (first_active != nullptr) {
      // The CPU one start costs (a soak restarts about a thousand processes an hour): user + system time of the
      // process from its start to its first active status.
      const double cpu = launcher::process_cpu_s(static_cast<int>(ps.pid()));
      if (cpu >= 0.0) heard_.start_cpu[first_active->role].push_back(cpu);
    }
    if (ps.role() == "world" && ps.deployment() == d_.name) {
      L_.on_world_load(ps.module_id(), ps.detail(), ps.tick(), now_s());
      if (ps.state() == static_cast<uint8_t>(runtime::Lifecycle::Finalized) && ps.detail() == "task done") {
        L_.on_world_done(ps.process_id(), ps.pid(), now_s());
      }
    }
  }
  serve_requests();
  watch_spins();
  if (recorder_stop_->exited()) {
    std::printf("tandem up: the recorder exited during the run (code %d); %s is incomplete\n", recorder_stop_->status(),
                d_.record.c_str());
    recording_failed_ = true;
  }
  // Shared-memory files of killed children, once no live process has used them for a minute (runtime::ShmSweeper:
  // removed 2 s after the kill, a segment could still be named in the port of a stalled listener, which would then
  // wedge for good: docs/soak.md, finding 71).
  const std::time_t wall = std::time(nullptr);
  if (sweeper_ && sweeper_->due(wall)) sweeper_->sweep(wall);
  if (L_.shm_dirty() && now_s() - L_.killed_at() > 2.0) {
    L_.shm_cleaned();
    if (sweeper_) sweeper_->sweep(wall);
    // And the port files of the participant ids no child holds now, unless a live process still has them open: a
    // newcomer given such an id then makes fresh ones (soak finding 59: after about a thousand kills, newcomers
    // that reopened a killed process's port files were heard by nobody, and modules could no longer start).
    if (d_.hosts.empty()) runtime::clean_free_ports(static_cast<int>(d_.domain_id), L_.free_participant_ids());
  }
  if (stop_ && !L_.stopping()) {
    std::printf("tandem up: stop requested; stopping %d process(es)\n", L_.running());
    L_.stop_all(SIGTERM, now_s());
  }
  const auto now = Clock::now();
  if (now - last_print_ > std::chrono::seconds(1)) {
    std::printf("[%5.1f s] processes running %d/%zu\n", std::chrono::duration<double>(now - t0_).count(), L_.running(),
                L_.children().size());
    view_.print(stdout);
    std::fflush(stdout);
    last_print_ = now;
  }
}

void UpRun::watch_spins() {
  if (d_.timing != "realtime" || d_.spin_limit <= 0.0 ||
      Clock::now() - spins_seen_ < std::chrono::seconds(1)) {
    return;
  }
  spins_seen_ = Clock::now();
  std::vector<launcher::ProcessThreads> procs;
  std::map<int, const launcher::Child*> by_pid;
  for (const launcher::Child& c : L_.children()) {
    if (!c.running || c.pid <= 0 || !c.host.empty() || c.role == "coordinator") continue;
    procs.push_back({c.pid, launcher::thread_times(c.pid)});
    by_pid[c.pid] = &c;
  }
  for (const launcher::SpinWatch::Spin& s : spins_.look(now_s(), procs)) {
    std::printf("tandem up: %s (pid %d): its thread %ld used %.0f%% of a core for %.1f s at %s, which no per-tick "
                "process does (a thread spinning: docs/soak.md, finding 85); killed (its exit is handled as a crash)\n",
                by_pid.at(s.pid)->label.c_str(), s.pid, s.tid, 100.0 * s.share, s.over_s, launcher::policy_name(s.policy));
    std::fflush(stdout);
    L_.on_spun(s.pid);
    ::kill(s.pid, SIGKILL);
  }
}

int UpRun::finish() {
  reap_local(L_, true);
  if (agent_out_) {  // the agents stop whatever is left of this run (--once agents exit)
    L_.heartbeat(true);
    (void)agent_out_->wait_for_acks(1.0);
  }
  size_t started_modules = 0;
  for (const auto& [name, mr] : L_.modules()) started_modules += mr.started ? 1 : 0;
  const auto settle = Clock::now();
  while (heard_.worlds.size() < started_modules && Clock::now() - settle < std::chrono::milliseconds(500)) {
    robot_sum_->wait(0.05);
    collect();
  }
  collect();

  std::ofstream out;
  bool failed = L_.failed();
  const bool grasp_ok = print_summary(std::chrono::duration<double>(Clock::now() - t0_).count(), L_, d_, heard_,
                                      o_.summary_file, out, failed);
  launcher_status_->set(runtime::Lifecycle::Finalized, "run over");
  viewer_stop_->stop();
  if (recorder_ > 0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the last summaries reach the recorder too
    std::fflush(stdout);
    recorder_stop_->stop();
    if (recorder_stop_->status() != 0) {
      std::printf("tandem up: the recorder failed (code %d): %s is incomplete\n", recorder_stop_->status(), d_.record.c_str());
      recording_failed_ = true;
    }
  }
  {
    msg::ProcessStatus ps;
    while (status_->take(ps)) view_.update(ps);
    std::printf("final states:\n");
    view_.print(stdout, LiveView::Rows::All);
  }
  // A process killed by a signal could not remove its shared-memory files: remove those of this run that no
  // live process uses (runtime::clean_stale_shm; also done during the run, after each killed child).
  bool killed = false;
  for (const auto& c : L_.children()) killed = killed || c.status >= 128;
  if (killed || !discovery_servers_.empty()) {
    for (auto& server : server_stops_) (void)::kill(server.pid(), SIGTERM);  // all at once, then each waited for
    for (auto& server : server_stops_) server.stop();
    std::this_thread::sleep_for(std::chrono::milliseconds(2100));  // the last files are 2 s old (clean_stale_shm)
    // Every child is gone. (ignore_self: files this process holds do not count; the launcher joins over UDP and
    // holds none of the deployment's now.)
    int removed = runtime::clean_stale_shm(launcher_started_, static_cast<int>(d_.domain_id), true);
    // The Discovery Server is a participant of domain 0 (its shared-memory port stays when it stops).
    if (!discovery_servers_.empty()) removed += runtime::clean_stale_shm(launcher_started_, 0, true);
    if (removed > 0) std::printf("removed %d shared-memory file(s) left by killed processes\n", removed);
  }
  if (d_.coordinator && !L_.coordinator_done()) failed = true;
  const bool ok = !failed && !stop_ && grasp_ok && !recording_failed_;
  if (out && d_.coordinator) out << "coordinator.done=" << (L_.coordinator_done() ? 1 : 0) << "\n";
  std::printf("result: %s\n", ok ? "PASS (all processes finished, safe grasp kept)"
                                 : (stop_ ? "STOPPED" : "FAIL (see above)"));
  return ok ? 0 : 1;
}

}  // namespace tandem::cli::up
