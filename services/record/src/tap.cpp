// The tap (tap.hpp): the recorder's and the viewer's reading of a deployment's domain. Per-tick samples are
// taken on the listener threads Fast DDS delivers them on (the same delivery the robots use: dds::shares_data);
// the keyed topics in poll().
#include "tandem/record/tap.hpp"

#include <tandemPubSubTypes.h>

#include <mutex>
#include <utility>

#include "tandem/dds/bus.hpp"
#include "tandem/record/event_deriver.hpp"
#include "tandem/record/recording.hpp"
#include "tandem/runtime/status.hpp"

namespace tandem::record {

namespace bus = tandem::dds;
namespace fdds = eprosima::fastdds::dds;
namespace pb = tandem::record;

namespace {

template <class Seq>
void copy_to(const Seq& from, google::protobuf::RepeatedField<double>* to) {
  for (const auto v : from) to->Add(static_cast<double>(v));
}
/// The first `n` entries only (a joint-space array of 4 slots holds the arm's joint count).
template <class Seq>
void copy_first(const Seq& from, size_t n, google::protobuf::RepeatedField<double>* to) {
  for (size_t i = 0; i < n && i < from.size(); ++i) to->Add(static_cast<double>(from[i]));
}

void copy_owners(const std::vector<msg::ArmOwner>& from,
                 google::protobuf::RepeatedPtrField<pb::ArmOwner>* to) {
  for (const auto& o : from) {
    pb::ArmOwner* p = to->Add();
    p->set_arm(o.arm());
    p->set_state(static_cast<pb::ArmState>(o.state()));
    p->set_robot(o.robot());
    p->set_strength(o.strength());
    p->set_handover_ticks(o.handover_ticks());
  }
}

// DDS -> Protobuf, field for field (idl/tandem.idl and idl/tandem_record.proto).
void convert(const msg::ArmSensors& s, pb::ArmSensors& o) {
  o.set_tick(s.tick());
  o.set_t(s.t());
  o.clear_q();
  o.clear_qd();
  o.clear_h();
  o.clear_tau();
  copy_first(s.q(), s.joints(), o.mutable_q());
  copy_first(s.qd(), s.joints(), o.mutable_qd());
  copy_to(s.h(), o.mutable_h());
  o.set_braked(s.braked());
  copy_first(s.tau(), s.joints(), o.mutable_tau());
  o.set_from(s.from());
  o.set_plan_epoch(s.plan_epoch());
  o.set_plan_strength(s.plan_strength());
  o.set_plan_version(s.plan_version());
  o.set_plan_since(s.plan_since());
  o.set_arm_kind(s.arm_kind());
  o.set_joints(s.joints());
}
void convert(const msg::TorqueCommand& c, pb::TorqueCommand& o) {
  o.set_tick(c.tick());
  o.clear_tau();
  o.clear_e_p();
  copy_first(c.tau(), c.joints(), o.mutable_tau());
  o.set_strength(c.strength());
  o.set_leaving(c.leaving());
  copy_to(c.e_p(), o.mutable_e_p());
  o.set_e_h(c.e_h());
  o.set_normal_force(c.normal_force());
  o.set_arm_kind(c.arm_kind());
  o.set_joints(c.joints());
}
pb::WorldReport convert(const msg::WorldReport& r) {
  pb::WorldReport o;
  o.set_module_id(r.module_id());
  o.set_tick(r.tick());
  for (const bool b : r.braked()) o.add_braked(b);
  o.set_hold(r.hold());
  o.set_braked_since(r.braked_since());
  o.set_released_at(r.released_at());
  o.set_normal_min(r.normal_min());
  copy_to(r.object(), o.mutable_object());
  o.set_slips(r.slips());
  o.set_contact_lost(r.contact_lost());
  o.set_late(r.late());
  o.set_failovers(r.failovers());
  o.set_load_paused(r.load_paused());
  copy_owners(r.owners(), o.mutable_owners());
  o.set_failed(r.failed());
  o.set_failure(r.failure());
  o.set_plan_epoch(r.plan_epoch());
  o.set_plan_strength(r.plan_strength());
  o.set_plan_version(r.plan_version());
  return o;
}
pb::ProcessStatus convert(const msg::ProcessStatus& s) {
  pb::ProcessStatus o;
  o.set_process_id(s.process_id());
  o.set_deployment(s.deployment());
  o.set_role(s.role());
  o.set_module_id(s.module_id());
  o.set_state(s.state());
  o.set_detail(s.detail());
  o.set_pid(s.pid());
  o.set_tick(s.tick());
  o.set_progress(s.progress());
  o.set_grasp_margin(s.grasp_margin());
  o.set_tracking_error(s.tracking_error());
  o.set_latency_p99_us(s.latency_p99_us());
  o.set_late(s.late());
  o.set_wear(s.wear());
  o.set_workload(s.workload());
  o.set_serving(static_cast<pb::ServingRole>(s.serving()));
  o.set_strength(s.strength());
  copy_owners(s.owners(), o.mutable_owners());
  for (const auto& label : s.runs()) o.add_runs(label);
  o.set_reply_seq(s.reply_seq());
  o.set_reply_ok(s.reply_ok());
  o.set_reply_text(s.reply_text());
  o.set_host(s.host());
  return o;
}
pb::RobotSummary convert(const msg::RobotSummary& s) {
  pb::RobotSummary o;
  o.set_arm_id(s.arm_id());
  o.set_robot_id(s.robot_id());
  o.set_ticks(s.ticks());
  o.set_ep_pos_rms(s.ep_pos_rms());
  o.set_ep_ori_rms(s.ep_ori_rms());
  o.set_ep_sel_rms(s.ep_sel_rms());
  o.set_eh_rms(s.eh_rms());
  o.set_min_normal_force(s.min_normal_force());
  o.set_max_normal_force(s.max_normal_force());
  o.set_rejected(s.rejected());
  return o;
}
pb::WorldSummary convert(const msg::WorldSummary& s) {
  pb::WorldSummary o;
  o.set_module_id(s.module_id());
  o.set_ticks(s.ticks());
  copy_to(s.q_final(), o.mutable_q_final());
  copy_to(s.object_final(), o.mutable_object_final());
  o.set_slip_events(s.slip_events());
  o.set_contact_lost(s.contact_lost());
  o.set_late_commands(s.late_commands());
  o.set_rejected_commands(s.rejected_commands());
  o.set_latency_p50_us(s.latency_p50_us());
  o.set_latency_p99_us(s.latency_p99_us());
  o.set_latency_max_us(s.latency_max_us());
  o.set_wake_late_p99_us(s.wake_late_p99_us());
  o.set_realtime(s.realtime());
  o.set_failovers(s.failovers());
  o.set_failover_max_ms(s.failover_max_ms());
  copy_to(s.switch_gap_ms(), o.mutable_switch_gap_ms());
  for (const bool b : s.switch_failover()) o.add_switch_failover(b);
  o.set_braked_ticks(s.braked_ticks());
  o.set_overruns(s.overruns());
  o.set_load_pauses(s.load_pauses());
  o.set_load_paused_ticks(s.load_paused_ticks());
  o.set_failover_last_ms(s.failover_last_ms());
  copy_to(s.switch_ep_max(), o.mutable_switch_ep_max());
  copy_to(s.switch_hn_min(), o.mutable_switch_hn_min());
  return o;
}
pb::TaskAssignment convert(const msg::TaskAssignment& a) {
  pb::TaskAssignment o;
  o.set_module_id(a.module_id());
  o.set_task_id(a.task_id());
  o.set_task_name(a.task_name());
  copy_to(a.waypoints(), o.mutable_waypoints());
  return o;
}
pb::TaskState convert(const msg::TaskState& s) {
  pb::TaskState o;
  o.set_module_id(s.module_id());
  o.set_task_id(s.task_id());
  o.set_state(s.state());
  o.set_tasks_done(s.tasks_done());
  o.set_tick(s.tick());
  o.set_deployment(s.deployment());
  return o;
}
pb::SupervisorPlan convert(const msg::SupervisorPlan& p) {
  pb::SupervisorPlan o;
  o.set_module_id(p.module_id());
  o.set_supervisor_id(p.supervisor_id());
  o.set_strength(p.strength());
  o.set_epoch(p.epoch());
  o.set_version(p.version());
  o.set_task_id(p.task_id());
  o.set_tasks_done(p.tasks_done());
  o.set_running(p.running());
  o.set_start_tick(p.start_tick());
  copy_to(p.waypoints(), o.mutable_waypoints());
  o.set_pause_requested(p.pause_requested());
  o.set_draining(p.draining());
  o.set_state(p.state());
  o.set_deployment(p.deployment());
  o.set_tau_start(p.tau_start());
  copy_to(p.rest(), o.mutable_rest());
  copy_to(p.path_start(), o.mutable_path_start());
  copy_to(p.breaks(), o.mutable_breaks());
  o.set_heard_tick(p.heard_tick());
  return o;
}
pb::ControlRequest convert(const msg::ControlRequest& r) {
  pb::ControlRequest o;
  o.set_deployment(r.deployment());
  o.set_command(static_cast<pb::ControlCommand>(r.command()));
  o.set_target_kind(static_cast<pb::TargetKind>(r.target_kind()));
  o.set_target(r.target());
  o.set_standby(r.standby());
  o.set_scenario(r.scenario());
  o.set_case_name(r.case_name());
  o.set_host(r.host());
  o.set_seq(r.seq());
  return o;
}

/// What the event deriver needs of a world's report.
WorldView world_view(const msg::WorldReport& wr) {
  WorldView w;
  w.tick = wr.tick();
  w.braked = {wr.braked()[0], wr.braked()[1]};
  w.load_paused = wr.load_paused();
  w.failed = wr.failed();
  w.failure = wr.failure();
  w.owners.reserve(wr.owners().size());
  for (const auto& o : wr.owners()) {
    w.owners.push_back({o.arm(), o.state() == msg::ARM_SERVED, o.strength(), runtime::owner_text(o)});
  }
  return w;
}

}  // namespace

struct Tap::Impl {
  Impl(TapConfig c, TapSink& s) : cfg(std::move(c)), sink(s) {}

  struct Listener : fdds::DataReaderListener {
    std::function<void(fdds::DataReader*)> fn;
    void on_data_available(fdds::DataReader* r) override { fn(r); }
  };
  /// The per-tick topics of one arm: taken on the DDS thread that delivers them.
  struct TickTap {
    std::string arm, sensors_topic, torques_topic;
    Impl* self = nullptr;
    Listener sensors_listener, torques_listener;
    std::unique_ptr<bus::Reader<msg::ArmSensors, msg::ArmSensorsPubSubType>> sensors;
    std::unique_ptr<bus::Reader<msg::TorqueCommand, msg::TorqueCommandPubSubType>> torques;
    msg::ArmSensors s;
    msg::TorqueCommand c;
    pb::ArmSensors ps;
    pb::TorqueCommand pc;
    long long last_tick = -1, first_tick = -1;
    std::map<int, long long> last_command;  ///< per robot strength: the last tick commanded
    uint64_t gaps = 0, gap_ticks = 0, sensor_samples = 0, torque_samples = 0, command_gaps = 0,
             command_gap_ticks = 0;
    void on_sensors(fdds::DataReader* r) {
      fdds::SampleInfo info;
      while (r->take_next_sample(&s, &info) == ReturnCode_t::RETCODE_OK) {
        if (!info.valid_data) continue;
        const uint64_t now = pb::now_ns();
        std::lock_guard<std::mutex> lock(self->mu);
        if (self->closing) return;
        const auto k = static_cast<long long>(s.tick());
        if (last_tick >= 0 && k > last_tick + 1) {
          ++gaps;
          gap_ticks += static_cast<uint64_t>(k - last_tick - 1);
          self->event_locked("gap", arm.substr(0, arm.find('/')), arm,
                             std::to_string(k - last_tick - 1) +
                                 " sensor sample(s) not received before tick " + std::to_string(k),
                             s.tick(), now);
        }
        if (k > last_tick) last_tick = k;
        if (first_tick < 0) first_tick = k;
        convert(s, ps);
        ++sensor_samples;
        self->sink.on_message(sensors_topic, ps, now, static_cast<uint64_t>(info.source_timestamp.to_ns()));
      }
    }
    void on_torques(fdds::DataReader* r) {
      fdds::SampleInfo info;
      while (r->take_next_sample(&c, &info) == ReturnCode_t::RETCODE_OK) {
        if (!info.valid_data) continue;
        const uint64_t now = pb::now_ns();
        std::lock_guard<std::mutex> lock(self->mu);
        if (self->closing) return;
        // A robot commands every tick it is given (lockstep, and standbys in shadow): a jump is a gap.
        long long& lc = last_command.emplace(c.strength(), -1).first->second;
        const auto k = static_cast<long long>(c.tick());
        if (lc >= 0 && k > lc + 1 && !c.leaving()) {
          ++command_gaps;
          command_gap_ticks += static_cast<uint64_t>(k - lc - 1);
          self->event_locked(
              "gap", arm.substr(0, arm.find('/')), arm + "@" + std::to_string(c.strength()),
              std::to_string(k - lc - 1) + " torque command(s) not received before tick " + std::to_string(k),
              c.tick(), now);
        }
        if (k > lc) lc = k;
        convert(c, pc);
        ++torque_samples;
        self->sink.on_message(torques_topic, pc, now, static_cast<uint64_t>(info.source_timestamp.to_ns()));
      }
    }
  };

  bool has(const char* group) const { return cfg.groups.count(group) != 0; }

  template <class M>
  void put(const std::string& topic, const M& m, uint64_t now) {
    std::lock_guard<std::mutex> lock(mu);
    if (!closing) sink.on_message(topic, m, now, 0);
  }
  void write_events(const std::vector<DerivedEvent>& events, uint64_t now) {
    if (events.empty()) return;
    std::lock_guard<std::mutex> lock(mu);
    for (const auto& e : events) event_locked(e.kind, e.module, e.subject, e.detail, e.tick, now);
  }
  void event_locked(const std::string& kind, const std::string& module, const std::string& subject,
                    const std::string& detail, uint64_t tick, uint64_t now) {
    if (closing || !has("events")) return;
    pb::Event e;
    e.set_kind(kind);
    e.set_module_id(module);
    e.set_subject(subject);
    e.set_detail(detail);
    e.set_tick(tick);
    sink.on_event(e, now);
  }

  TapConfig cfg;
  TapSink& sink;
  std::mutex mu;  ///< the sink: per-tick listener threads and poll()
  bool closing = false;
  std::vector<std::unique_ptr<TickTap>> taps;
  std::map<std::string, std::unique_ptr<bus::Reader<msg::WorldReport, msg::WorldReportPubSubType>>> reports;
  std::map<std::string, std::unique_ptr<bus::Reader<msg::SupervisorPlan, msg::SupervisorPlanPubSubType>>>
      plans;
  std::unique_ptr<bus::Reader<msg::ProcessStatus, msg::ProcessStatusPubSubType>> status;
  std::unique_ptr<bus::Reader<msg::RobotSummary, msg::RobotSummaryPubSubType>> robot_sum;
  std::unique_ptr<bus::Reader<msg::WorldSummary, msg::WorldSummaryPubSubType>> world_sum;
  std::unique_ptr<bus::Reader<msg::TaskAssignment, msg::TaskAssignmentPubSubType>> assign;
  std::unique_ptr<bus::Reader<msg::TaskState, msg::TaskStatePubSubType>> task_state;
  std::unique_ptr<bus::Reader<msg::ControlRequest, msg::ControlRequestPubSubType>> control;
  EventDeriver deriver;  ///< events from what is taken (poll() only)
  int launcher_state = -1;
  std::map<std::string, uint64_t> world_ticks;  ///< module -> ticks of its world's summary (under mu)
};

Tap::Tap(TapConfig config, TapSink& sink) : impl_(std::make_unique<Impl>(std::move(config), sink)) {}

Tap::~Tap() {
  close();
  // The per-tick readers go first: their listener threads must not outlive the taps they call.
  for (auto& t : impl_->taps) {
    t->sensors.reset();
    t->torques.reset();
  }
}

void Tap::start(dds::Participant& part) {
  Impl& I = *impl_;
  auto reader_kind = [](bool rt, bool sensors) {
    if (sensors) return rt ? bus::TopicKind::SensorsRealtime : bus::TopicKind::Sensors;
    return rt ? bus::TopicKind::TorquesRealtime : bus::TopicKind::Torques;
  };
  if (I.has("ticks")) {
    for (const auto& arm : I.cfg.arms) {
      auto t = std::make_unique<Impl::TickTap>();
      t->arm = arm;
      t->self = &I;
      t->sensors_topic = bus::arm_topic(bus::kSensorsTopic, arm);
      t->torques_topic = bus::arm_topic(bus::kTorquesTopic, arm);
      t->sensors_listener.fn = [tap = t.get()](fdds::DataReader* r) { tap->on_sensors(r); };
      t->torques_listener.fn = [tap = t.get()](fdds::DataReader* r) { tap->on_torques(r); };
      I.taps.push_back(std::move(t));
    }
    for (auto& t : I.taps) {
      t->sensors = std::make_unique<bus::Reader<msg::ArmSensors, msg::ArmSensorsPubSubType>>(
          part, t->sensors_topic, reader_kind(I.cfg.realtime, true), &t->sensors_listener);
      t->torques = std::make_unique<bus::Reader<msg::TorqueCommand, msg::TorqueCommandPubSubType>>(
          part, t->torques_topic, reader_kind(I.cfg.realtime, false), &t->torques_listener);
    }
  }
  if (I.has("world") || I.has("events")) {
    for (const auto& m : I.cfg.modules) {
      I.reports[m] = std::make_unique<bus::Reader<msg::WorldReport, msg::WorldReportPubSubType>>(
          part, bus::module_topic(bus::kWorldReportTopic, m), bus::TopicKind::Record);
    }
  }
  if (I.has("tasks")) {
    for (const auto& m : I.cfg.modules) {
      I.plans[m] = std::make_unique<bus::Reader<msg::SupervisorPlan, msg::SupervisorPlanPubSubType>>(
          part, bus::module_topic(bus::kSupervisorPlanTopic, m), bus::TopicKind::Record);
    }
  }
  I.status = std::make_unique<bus::Reader<msg::ProcessStatus, msg::ProcessStatusPubSubType>>(
      part, bus::kStatusTopic, bus::TopicKind::Record);
  I.robot_sum = std::make_unique<bus::Reader<msg::RobotSummary, msg::RobotSummaryPubSubType>>(
      part, bus::kRobotSummaryTopic, bus::TopicKind::Record);
  I.world_sum = std::make_unique<bus::Reader<msg::WorldSummary, msg::WorldSummaryPubSubType>>(
      part, bus::kWorldSummaryTopic, bus::TopicKind::Record);
  I.assign = std::make_unique<bus::Reader<msg::TaskAssignment, msg::TaskAssignmentPubSubType>>(
      part, bus::kTaskAssignmentTopic, bus::TopicKind::Record);
  I.task_state = std::make_unique<bus::Reader<msg::TaskState, msg::TaskStatePubSubType>>(
      part, bus::kTaskStateTopic, bus::TopicKind::Record);
  I.control = std::make_unique<bus::Reader<msg::ControlRequest, msg::ControlRequestPubSubType>>(
      part, bus::kControlTopic, bus::TopicKind::Control);
}

void Tap::poll() {
  Impl& I = *impl_;
  if (!I.status) return;  // not started
  const uint64_t now = pb::now_ns();
  const std::string& name = I.cfg.deployment;
  msg::ProcessStatus ps;
  while (I.status->take(ps)) {
    if (!ps.deployment().empty() && ps.deployment() != name) continue;
    if (ps.process_id() == "launcher") I.launcher_state = ps.state();
    if (I.has("status")) I.put(bus::kStatusTopic, convert(ps), now);
    // A coordinator's tick is its queue's next task id, not a world tick: its events carry none.
    I.write_events(I.deriver.on_status(ps.process_id(), ps.module_id(), ps.state(), ps.detail(),
                                       ps.role() == "coordinator" ? 0 : ps.tick()),
                   now);
  }
  for (auto& [module, r] : I.reports) {
    msg::WorldReport wr;
    while (r->take(wr)) {
      if (wr.module_id() != module) continue;
      if (I.has("world")) I.put(bus::module_topic(bus::kWorldReportTopic, module), convert(wr), now);
      I.write_events(I.deriver.on_world(module, world_view(wr)), now);
    }
  }
  for (auto& [module, r] : I.plans) {
    msg::SupervisorPlan p;
    while (r->take(p)) {
      if (p.module_id() == module)
        I.put(bus::module_topic(bus::kSupervisorPlanTopic, module), convert(p), now);
    }
  }
  msg::RobotSummary rs;
  while (I.robot_sum->take(rs)) {
    if (I.has("summaries")) I.put(bus::kRobotSummaryTopic, convert(rs), now);
  }
  msg::WorldSummary ws;
  while (I.world_sum->take(ws)) {
    {
      std::lock_guard<std::mutex> lock(I.mu);
      I.world_ticks[ws.module_id()] = ws.ticks();
    }
    if (I.has("summaries")) I.put(bus::kWorldSummaryTopic, convert(ws), now);
  }
  msg::TaskAssignment ta;
  while (I.assign->take(ta)) {
    if (I.has("tasks")) I.put(bus::kTaskAssignmentTopic, convert(ta), now);
    I.write_events(I.deriver.on_assignment(ta.task_id(), ta.module_id(), ta.task_name()), now);
  }
  msg::TaskState ts;
  while (I.task_state->take(ts)) {
    if (!ts.deployment().empty() && ts.deployment() != name) continue;
    if (I.has("tasks")) I.put(bus::kTaskStateTopic, convert(ts), now);
    I.write_events(I.deriver.on_task_state(ts.module_id(), ts.task_id(), ts.tasks_done(), ts.tick()), now);
  }
  msg::ControlRequest cr;
  while (I.control->take(cr)) {
    if (cr.deployment() != name) continue;
    if (I.has("control")) I.put(bus::kControlTopic, convert(cr), now);
    std::string option = cr.command() == msg::CMD_PLUG && cr.target_kind() == msg::TARGET_ROBOT
                             ? (cr.standby() ? "standby" : "primary")
                         : cr.scenario().empty() ? ""
                                                 : cr.scenario() + " " + cr.case_name();
    I.write_events(I.deriver.on_control(runtime::command_name(cr.command()), cr.target(), option), now);
  }
}

void Tap::locked(const std::function<void()>& f) {
  std::lock_guard<std::mutex> lock(impl_->mu);
  f();
}

void Tap::close() {
  std::lock_guard<std::mutex> lock(impl_->mu);
  impl_->closing = true;
}

int Tap::launcher_state() const {
  return impl_->launcher_state;
}

std::map<std::string, ArmTapStats> Tap::stats() {
  std::lock_guard<std::mutex> lock(impl_->mu);
  std::map<std::string, ArmTapStats> out;
  for (const auto& t : impl_->taps) {
    // Besides the gaps seen between samples: ticks before the first sample and after the last one, against
    // the world's own count (its summary, when it was heard), and torque commands that skipped ticks.
    uint64_t missed = t->gap_ticks + t->command_gap_ticks, holes = t->gaps + t->command_gaps;
    const auto w = impl_->world_ticks.find(t->arm.substr(0, t->arm.find('/')));
    if (w != impl_->world_ticks.end() && w->second > 0) {
      const auto world = static_cast<long long>(w->second);
      const long long head = t->first_tick < 0 ? world : t->first_tick;
      const long long tail = t->last_tick < 0 ? 0 : world - 1 - t->last_tick;
      if (head > 0) missed += static_cast<uint64_t>(head), ++holes;
      if (tail > 0) missed += static_cast<uint64_t>(tail), ++holes;
    }
    out[t->arm] = {t->sensor_samples, t->torque_samples, missed, holes};
  }
  return out;
}

}  // namespace tandem::record
