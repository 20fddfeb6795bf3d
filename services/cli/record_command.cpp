// tandem record: a DDS participant of a deployment's domain that writes the chosen topics to an MCAP file
// with Protobuf messages (services/record, docs/recording.md). Started by `tandem up` when the deployment has
// `record:` (or `tandem up --record FILE`), or by hand beside a running deployment. It only reads: per-tick
// samples arrive by the same data-sharing delivery the robots use, on the recorder's own listener threads,
// and are converted and appended to an in-memory chunk (written out every 1 MiB or second).
#include "record_command.hpp"

#include <tandemPubSubTypes.h>
#include <tandem_record.pb.h>

#include <sys/resource.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <functional>
#include <iterator>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "tandem/record/event_deriver.hpp"
#include "tandem/record/recording.hpp"
#include "tandem/runtime/deployment.hpp"
#include "tandem/runtime/security.hpp"
#include "tandem/runtime/status.hpp"
#include "tandem/sim/module_setup.hpp"
#include "tandem/sim/scenario_yaml.hpp"

namespace tandem::cli {

namespace bus = tandem::dds;
namespace fdds = eprosima::fastdds::dds;
namespace pb = tandem::record;
using Clock = std::chrono::steady_clock;

namespace {

std::atomic<bool> g_record_stop{false};
void on_record_signal(int) { g_record_stop = true; }

const std::set<std::string> kGroups(std::begin(runtime::kRecordGroups), std::end(runtime::kRecordGroups));

template <class Seq>
void copy_to(const Seq& from, google::protobuf::RepeatedField<double>* to) {
  for (const auto v : from) to->Add(static_cast<double>(v));
}

void copy_owners(const std::vector<msg::ArmOwner>& from, google::protobuf::RepeatedPtrField<pb::ArmOwner>* to) {
  for (const auto& o : from) {
    pb::ArmOwner* p = to->Add();
    p->set_arm(o.arm());
    p->set_state(static_cast<pb::ArmState>(o.state()));
    p->set_robot(o.robot());
    p->set_strength(o.strength());
  }
}

// DDS -> Protobuf, field for field (idl/tandem.idl and idl/tandem_record.proto).
void convert(const msg::ArmSensors& s, pb::ArmSensors& o) {
  o.set_tick(s.tick());
  o.set_t(s.t());
  o.clear_q(); o.clear_qd(); o.clear_h(); o.clear_tau();
  copy_to(s.q(), o.mutable_q());
  copy_to(s.qd(), o.mutable_qd());
  copy_to(s.h(), o.mutable_h());
  o.set_braked(s.braked());
  copy_to(s.tau(), o.mutable_tau());
  o.set_from(s.from());
  o.set_plan_epoch(s.plan_epoch());
  o.set_plan_strength(s.plan_strength());
  o.set_plan_version(s.plan_version());
  o.set_plan_since(s.plan_since());
}
void convert(const msg::TorqueCommand& c, pb::TorqueCommand& o) {
  o.set_tick(c.tick());
  o.clear_tau(); o.clear_e_p();
  copy_to(c.tau(), o.mutable_tau());
  o.set_strength(c.strength());
  o.set_leaving(c.leaving());
  copy_to(c.e_p(), o.mutable_e_p());
  o.set_e_h(c.e_h());
  o.set_normal_force(c.normal_force());
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
record::WorldView world_view(const msg::WorldReport& wr) {
  record::WorldView w;
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

/// The recorder: one participant, a reader per chosen topic, one writer of the file.
class Recorder {
 public:
  Recorder(const runtime::Deployment& d, const std::string& file, const std::string& out, std::set<std::string> groups)
      : d_(d), groups_(std::move(groups)), w_(out) {
    realtime_ = d.timing == "realtime";
    std::map<std::string, std::string> meta{{"deployment", d.name},
                                            {"deployment_file", file},
                                            {"timing", d.timing},
                                            {"domain", std::to_string(d.domain_id)},
                                            {"transport", d.transport},
                                            {"modules", ""},
                                            {"topics", ""}};
    for (const auto& g : groups_) meta["topics"] += (meta["topics"].empty() ? "" : ",") + g;
    for (const auto& m : d.modules) {
      const sim::Scenario sc = sim::load_scenario(m.scenario);
      double h_sg = 0.0, period = 0.0;
      for (const auto& c : sc.cases) {
        if (c.name == m.case_name) {
          const sim::ModuleSetup ms = sim::make_module(sc, c);
          h_sg = ms.safe_grasp_force;
          period = ms.period;
        }
      }
      meta["modules"] += (meta["modules"].empty() ? "" : ",") + m.name;
      meta["module." + m.name + ".h_sg"] = std::to_string(h_sg);
      meta["module." + m.name + ".period"] = std::to_string(period);
      meta["module." + m.name + ".arms"] = m.name + "/" + sc.robots[0].name + "," + m.name + "/" + sc.robots[1].name;
      meta["module." + m.name + ".scenario"] = m.scenario;
      meta["module." + m.name + ".case"] = m.case_name;
      for (int j = 0; j < 2; ++j) arms_.push_back(m.name + "/" + sc.robots[j].name);
    }
    w_.metadata("deployment", meta);
    events_ = w_.channel("tandem/events", pb::Event::descriptor());
  }

  void start(bus::Participant& part) {
    auto reader_kind = [](bool rt, bool sensors) {
      if (sensors) return rt ? bus::TopicKind::SensorsRealtime : bus::TopicKind::Sensors;
      return rt ? bus::TopicKind::TorquesRealtime : bus::TopicKind::Torques;
    };
    if (groups_.count("ticks") != 0) {
      // Every channel first: once the first reader exists its listener thread writes to the file, and the
      // writer's channel table is not to be changed beside it (channels of keyed topics are made under mu_).
      for (const auto& arm : arms_) {
        auto t = std::make_unique<TickTap>();
        t->arm = arm;
        t->self = this;
        t->sensors_channel = w_.channel(bus::arm_topic(bus::kSensorsTopic, arm), pb::ArmSensors::descriptor(),
                                        {{"arm", arm}});
        t->torques_channel = w_.channel(bus::arm_topic(bus::kTorquesTopic, arm), pb::TorqueCommand::descriptor(),
                                        {{"arm", arm}});
        t->sensors_listener.fn = [tap = t.get()](fdds::DataReader* r) { tap->on_sensors(r); };
        t->torques_listener.fn = [tap = t.get()](fdds::DataReader* r) { tap->on_torques(r); };
        taps_.push_back(std::move(t));
      }
      for (auto& t : taps_) {
        t->sensors = std::make_unique<bus::Reader<msg::ArmSensors, msg::ArmSensorsPubSubType>>(
            part, bus::arm_topic(bus::kSensorsTopic, t->arm), reader_kind(realtime_, true), &t->sensors_listener);
        t->torques = std::make_unique<bus::Reader<msg::TorqueCommand, msg::TorqueCommandPubSubType>>(
            part, bus::arm_topic(bus::kTorquesTopic, t->arm), reader_kind(realtime_, false), &t->torques_listener);
      }
    }
    if (groups_.count("world") != 0 || groups_.count("events") != 0) {
      for (const auto& m : d_.modules) {
        reports_[m.name] = std::make_unique<bus::Reader<msg::WorldReport, msg::WorldReportPubSubType>>(
            part, bus::module_topic(bus::kWorldReportTopic, m.name), bus::TopicKind::Record);
      }
    }
    if (groups_.count("tasks") != 0) {
      for (const auto& m : d_.modules) {
        plans_[m.name] = std::make_unique<bus::Reader<msg::SupervisorPlan, msg::SupervisorPlanPubSubType>>(
            part, bus::module_topic(bus::kSupervisorPlanTopic, m.name), bus::TopicKind::Record);
      }
    }
    status_ = std::make_unique<bus::Reader<msg::ProcessStatus, msg::ProcessStatusPubSubType>>(part, bus::kStatusTopic,
                                                                                             bus::TopicKind::Record);
    robot_sum_ = std::make_unique<bus::Reader<msg::RobotSummary, msg::RobotSummaryPubSubType>>(
        part, bus::kRobotSummaryTopic, bus::TopicKind::Record);
    world_sum_ = std::make_unique<bus::Reader<msg::WorldSummary, msg::WorldSummaryPubSubType>>(
        part, bus::kWorldSummaryTopic, bus::TopicKind::Record);
    assign_ = std::make_unique<bus::Reader<msg::TaskAssignment, msg::TaskAssignmentPubSubType>>(
        part, bus::kTaskAssignmentTopic, bus::TopicKind::Record);
    task_state_ = std::make_unique<bus::Reader<msg::TaskState, msg::TaskStatePubSubType>>(part, bus::kTaskStateTopic,
                                                                                       bus::TopicKind::Record);
    control_ = std::make_unique<bus::Reader<msg::ControlRequest, msg::ControlRequestPubSubType>>(
        part, bus::kControlTopic, bus::TopicKind::Control);
  }

  /// Takes what the keyed topics hold (called every 20 ms by the main loop) and writes the file out every second.
  void poll() {
    const uint64_t now = pb::now_ns();
    msg::ProcessStatus ps;
    fdds::SampleInfo info;
    while (status_->take(ps)) {
      if (!ps.deployment().empty() && ps.deployment() != d_.name) continue;
      if (ps.process_id() == "launcher") launcher_state_ = ps.state();
      if (groups_.count("status") != 0) put("tandem/process_status", convert(ps), now);
      write_events(deriver_.on_status(ps.process_id(), ps.module_id(), ps.state(), ps.detail(), ps.tick()), now);
    }
    for (auto& [module, r] : reports_) {
      msg::WorldReport wr;
      while (r->take(wr)) {
        if (wr.module_id() != module) continue;
        if (groups_.count("world") != 0) put(bus::module_topic(bus::kWorldReportTopic, module), convert(wr), now);
        write_events(deriver_.on_world(module, world_view(wr)), now);
      }
    }
    for (auto& [module, r] : plans_) {
      msg::SupervisorPlan p;
      while (r->take(p)) {
        if (p.module_id() == module) put(bus::module_topic(bus::kSupervisorPlanTopic, module), convert(p), now);
      }
    }
    msg::RobotSummary rs;
    while (robot_sum_->take(rs)) {
      if (groups_.count("summaries") != 0) put(bus::kRobotSummaryTopic, convert(rs), now);
    }
    msg::WorldSummary ws;
    while (world_sum_->take(ws)) {
      {
        std::lock_guard<std::mutex> lock(mu_);
        world_ticks_[ws.module_id()] = ws.ticks();
      }
      if (groups_.count("summaries") != 0) put(bus::kWorldSummaryTopic, convert(ws), now);
    }
    msg::TaskAssignment ta;
    while (assign_->take(ta)) {
      if (groups_.count("tasks") != 0) put(bus::kTaskAssignmentTopic, convert(ta), now);
      write_events(deriver_.on_assignment(ta.task_id(), ta.module_id(), ta.task_name()), now);
    }
    msg::TaskState ts;
    while (task_state_->take(ts)) {
      if (!ts.deployment().empty() && ts.deployment() != d_.name) continue;
      if (groups_.count("tasks") != 0) put(bus::kTaskStateTopic, convert(ts), now);
      write_events(deriver_.on_task_state(ts.module_id(), ts.task_id(), ts.tasks_done(), ts.tick()), now);
    }
    msg::ControlRequest cr;
    while (control_->take(cr)) {
      if (cr.deployment() != d_.name) continue;
      if (groups_.count("control") != 0) put(bus::kControlTopic, convert(cr), now);
      std::string option = cr.command() == msg::CMD_PLUG && cr.target_kind() == msg::TARGET_ROBOT
                               ? (cr.standby() ? "standby" : "primary")
                               : cr.scenario().empty() ? "" : cr.scenario() + " " + cr.case_name();
      write_events(deriver_.on_control(runtime::command_name(cr.command()), cr.target(), option), now);
    }
    std::lock_guard<std::mutex> lock(mu_);
    if (Clock::now() - last_flush_ > std::chrono::seconds(1)) {  // a crash loses at most a second
      w_.flush();
      last_flush_ = Clock::now();
    }
  }

  int launcher_state() const { return launcher_state_; }

  /// Closes the file; returns a one-line account.
  std::string finish() {
    std::lock_guard<std::mutex> lock(mu_);
    closing_ = true;
    uint64_t gaps = 0, gap_ticks = 0, per_tick = 0;
    std::map<std::string, std::string> stats;
    for (const auto& t : taps_) {
      // Besides the gaps seen between samples: ticks before the first sample and after the last one, against the
      // world's own count (its summary, when it was heard), and torque commands that skipped ticks.
      uint64_t missed = t->gap_ticks + t->command_gap_ticks, holes = t->gaps + t->command_gaps;
      const auto w = world_ticks_.find(t->arm.substr(0, t->arm.find('/')));
      if (w != world_ticks_.end() && w->second > 0) {
        const auto world = static_cast<long long>(w->second);
        const long long head = t->first_tick < 0 ? world : t->first_tick;
        const long long tail = t->last_tick < 0 ? 0 : world - 1 - t->last_tick;
        if (head > 0) missed += static_cast<uint64_t>(head), ++holes;
        if (tail > 0) missed += static_cast<uint64_t>(tail), ++holes;
      }
      gaps += holes;
      gap_ticks += missed;
      per_tick += t->sensor_samples + t->torque_samples;
      stats["arm." + t->arm + ".sensor_samples"] = std::to_string(t->sensor_samples);
      stats["arm." + t->arm + ".torque_samples"] = std::to_string(t->torque_samples);
      stats["arm." + t->arm + ".missed_ticks"] = std::to_string(missed);
    }
    stats["messages"] = std::to_string(w_.messages());
    stats["gaps"] = std::to_string(gaps);
    stats["missed_ticks"] = std::to_string(gap_ticks);
    w_.metadata("recorder", stats);
    w_.close();
    char buf[256];
    std::snprintf(buf, sizeof buf, "%llu messages (%llu per-tick samples), %.1f MiB; %llu tick(s) missed in %llu gap(s)",
                  static_cast<unsigned long long>(w_.messages()), static_cast<unsigned long long>(per_tick),
                  static_cast<double>(w_.bytes()) / (1024.0 * 1024.0), static_cast<unsigned long long>(gap_ticks),
                  static_cast<unsigned long long>(gaps));
    return buf;
  }

 private:
  struct Listener : fdds::DataReaderListener {
    std::function<void(fdds::DataReader*)> fn;
    void on_data_available(fdds::DataReader* r) override { fn(r); }
  };
  /// The per-tick topics of one arm: taken on the DDS thread that delivers them.
  struct TickTap {
    std::string arm;
    Recorder* self = nullptr;
    uint16_t sensors_channel = 0, torques_channel = 0;
    Listener sensors_listener, torques_listener;
    std::unique_ptr<bus::Reader<msg::ArmSensors, msg::ArmSensorsPubSubType>> sensors;
    std::unique_ptr<bus::Reader<msg::TorqueCommand, msg::TorqueCommandPubSubType>> torques;
    msg::ArmSensors s;
    msg::TorqueCommand c;
    pb::ArmSensors ps;
    pb::TorqueCommand pc;
    long long last_tick = -1, first_tick = -1;
    std::map<int, long long> last_command;  ///< per robot strength: the last tick commanded
    uint64_t gaps = 0, gap_ticks = 0, sensor_samples = 0, torque_samples = 0, command_gaps = 0, command_gap_ticks = 0;
    void on_sensors(fdds::DataReader* r) {
      fdds::SampleInfo info;
      while (r->take_next_sample(&s, &info) == ReturnCode_t::RETCODE_OK) {
        if (!info.valid_data) continue;
        const uint64_t now = pb::now_ns();
        std::lock_guard<std::mutex> lock(self->mu_);
        if (self->closing_) return;
        const auto k = static_cast<long long>(s.tick());
        if (last_tick >= 0 && k > last_tick + 1) {
          ++gaps;
          gap_ticks += static_cast<uint64_t>(k - last_tick - 1);
          self->event_locked("gap", arm.substr(0, arm.find('/')), arm,
                             std::to_string(k - last_tick - 1) + " sensor sample(s) not received before tick " +
                                 std::to_string(k), s.tick(), now);
        }
        if (k > last_tick) last_tick = k;
        if (first_tick < 0) first_tick = k;
        convert(s, ps);
        ++sensor_samples;
        self->w_.write(sensors_channel, ps, now, static_cast<uint64_t>(info.source_timestamp.to_ns()));
      }
    }
    void on_torques(fdds::DataReader* r) {
      fdds::SampleInfo info;
      while (r->take_next_sample(&c, &info) == ReturnCode_t::RETCODE_OK) {
        if (!info.valid_data) continue;
        const uint64_t now = pb::now_ns();
        std::lock_guard<std::mutex> lock(self->mu_);
        if (self->closing_) return;
        // A robot commands every tick it is given (lockstep, and standbys in shadow): a jump is a gap.
        long long& lc = last_command.emplace(c.strength(), -1).first->second;
        const auto k = static_cast<long long>(c.tick());
        if (lc >= 0 && k > lc + 1 && !c.leaving()) {
          ++command_gaps;
          command_gap_ticks += static_cast<uint64_t>(k - lc - 1);
          self->event_locked("gap", arm.substr(0, arm.find('/')), arm + "@" + std::to_string(c.strength()),
                             std::to_string(k - lc - 1) + " torque command(s) not received before tick " +
                                 std::to_string(k), c.tick(), now);
        }
        if (k > lc) lc = k;
        convert(c, pc);
        ++torque_samples;
        self->w_.write(torques_channel, pc, now, static_cast<uint64_t>(info.source_timestamp.to_ns()));
      }
    }
  };

  template <class M>
  void put(const std::string& topic, const M& m, uint64_t now) {
    std::lock_guard<std::mutex> lock(mu_);
    if (closing_) return;
    w_.write(w_.channel(topic, M::descriptor()), m, now);
  }
  void write_events(const std::vector<record::DerivedEvent>& events, uint64_t now) {
    if (events.empty()) return;
    std::lock_guard<std::mutex> lock(mu_);
    for (const auto& e : events) event_locked(e.kind, e.module, e.subject, e.detail, e.tick, now);
  }
  void event_locked(const std::string& kind, const std::string& module, const std::string& subject,
                    const std::string& detail, uint64_t tick, uint64_t now) {
    if (closing_ || groups_.count("events") == 0) return;
    pb::Event e;
    e.set_kind(kind);
    e.set_module_id(module);
    e.set_subject(subject);
    e.set_detail(detail);
    e.set_tick(tick);
    w_.write(events_, e, now);
  }
  const runtime::Deployment& d_;
  std::set<std::string> groups_;
  bool realtime_ = false;
  std::mutex mu_;  ///< the writer: per-tick listener threads and the main loop
  pb::RecordingWriter w_;
  bool closing_ = false;
  Clock::time_point last_flush_ = Clock::now();
  uint16_t events_ = 0;
  std::vector<std::string> arms_;
  std::vector<std::unique_ptr<TickTap>> taps_;
  std::map<std::string, std::unique_ptr<bus::Reader<msg::WorldReport, msg::WorldReportPubSubType>>> reports_;
  std::map<std::string, std::unique_ptr<bus::Reader<msg::SupervisorPlan, msg::SupervisorPlanPubSubType>>> plans_;
  std::unique_ptr<bus::Reader<msg::ProcessStatus, msg::ProcessStatusPubSubType>> status_;
  std::unique_ptr<bus::Reader<msg::RobotSummary, msg::RobotSummaryPubSubType>> robot_sum_;
  std::unique_ptr<bus::Reader<msg::WorldSummary, msg::WorldSummaryPubSubType>> world_sum_;
  std::unique_ptr<bus::Reader<msg::TaskAssignment, msg::TaskAssignmentPubSubType>> assign_;
  std::unique_ptr<bus::Reader<msg::TaskState, msg::TaskStatePubSubType>> task_state_;
  std::unique_ptr<bus::Reader<msg::ControlRequest, msg::ControlRequestPubSubType>> control_;
  record::EventDeriver deriver_;  ///< events from what is taken (the main loop only)
  int launcher_state_ = -1;
  std::map<std::string, uint64_t> world_ticks_;  ///< module -> ticks of its world's summary (under mu_)
};

}  // namespace

void record_usage(std::FILE* f) {
  std::fputs(
      "usage: tandem record <deploy.yaml> -o FILE.mcap [--topics LIST] [--duration SECONDS] [--attached]\n"
      "\n"
      "Joins the deployment's DDS domain as its own participant and writes what it hears to an MCAP file\n"
      "with Protobuf messages (schema idl/tandem_record.proto; each schema record holds the FileDescriptorSet,\n"
      "so Foxglove Studio, the mcap CLI or any MCAP library decodes it). Start it beside a running deployment,\n"
      "or let `tandem up` start it: `record: FILE` in the deployment, or `tandem up --record FILE`.\n"
      "\n"
      "  -o, --out FILE    the recording to write (overwritten)\n"
      "  --topics LIST     comma-separated groups (default: all):\n"
      "                      ticks      arm sensors and torque commands of every arm, every tick\n"
      "                      world      the worlds' reports (brakes, holds, owners, counters), every 10 ticks\n"
      "                      status     every process's status (about every 100 ms)\n"
      "                      tasks      task assignments, task states, the supervisors' plans\n"
      "                      summaries  robot and world summaries at the end of a run\n"
      "                      control    control requests (down, kill, plug, unplug, pause, ...)\n"
      "                      events     lifecycle changes, failovers/takeovers, brakes, pauses, tasks, gaps\n"
      "  --duration S      stop after S seconds (default: until Ctrl-C, SIGTERM, or the deployment's launcher\n"
      "                    finishes)\n"
      "  --attached        started by `tandem up`: stop only on SIGTERM (the launcher stops it last)\n"
      "\n"
      "Per-tick topics are read with the robots' QoS: in lockstep nothing is lost (the world waits for the\n"
      "recorder to match before its first tick); in real time samples are best effort and a tick the recorder\n"
      "did not get is logged as a 'gap' event. Use `tandem report FILE.mcap -o DIR` for plots.\n"
      "Exit: 0 written, 1 the file could not be written completely, 2 bad command line or deployment.\n",
      f);
}

int record_command(const std::vector<std::string>& args) {
  std::string file, out;
  std::set<std::string> groups = kGroups;
  double duration = 0.0;
  bool attached = false;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&](const char* what) -> const std::string* {
      if (i + 1 >= args.size()) {
        std::fprintf(stderr, "tandem record: %s needs %s\n", a.c_str(), what);
        return nullptr;
      }
      return &args[++i];
    };
    if (a == "--help" || a == "-h") {
      record_usage(stdout);
      return 0;
    } else if (a == "-o" || a == "--out") {
      const std::string* v = value("a file name");
      if (v == nullptr) return 2;
      out = *v;
    } else if (a == "--topics") {
      const std::string* v = value("a list of groups");
      if (v == nullptr) return 2;
      groups.clear();
      std::stringstream ss(*v);
      std::string g;
      while (std::getline(ss, g, ',')) {
        if (g == "all") {
          groups = kGroups;
        } else if (kGroups.count(g) == 0) {
          std::fprintf(stderr, "tandem record: unknown topic group '%s'; accepted: all, ticks, world, status, tasks, "
                               "summaries, control, events\n", g.c_str());
          return 2;
        } else {
          groups.insert(g);
        }
      }
      if (groups.empty()) {
        std::fprintf(stderr, "tandem record: --topics names no group\n");
        return 2;
      }
    } else if (a == "--duration") {
      const std::string* v = value("seconds");
      if (v == nullptr) return 2;
      char* end = nullptr;
      duration = std::strtod(v->c_str(), &end);
      if (end == v->c_str() || *end != '\0' || !(duration > 0.0) || duration > 1e7) {
        std::fprintf(stderr, "tandem record: --duration '%s' is not a number of seconds > 0\n", v->c_str());
        return 2;
      }
    } else if (a == "--attached") {
      attached = true;
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "tandem record: unknown option '%s' (see 'tandem help record')\n", a.c_str());
      return 2;
    } else if (file.empty()) {
      file = a;
    } else {
      std::fprintf(stderr, "tandem record: one deployment file expected, got '%s' too\n", a.c_str());
      return 2;
    }
  }
  if (file.empty() || out.empty()) {
    std::fprintf(stderr, "tandem record: %s\n\n", file.empty() ? "missing the deployment file" : "missing -o FILE.mcap");
    record_usage(stderr);
    return 2;
  }
  runtime::Deployment d;
  try {
    d = runtime::load_deployment(file);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem record: %s\n", e.what());
    return 2;
  }
  struct sigaction sa {};
  sa.sa_handler = on_record_signal;
  ::sigaction(SIGTERM, &sa, nullptr);
  // Started by the launcher, it shares the terminal's process group: Ctrl-C is for the launcher, which stops the
  // recorder last (SIGTERM), after the modules' final summaries.
  if (attached) {
    ::signal(SIGINT, SIG_IGN);
  } else {
    ::sigaction(SIGINT, &sa, nullptr);
  }
  runtime::use_discovery(d);
  if (const std::string err = runtime::use_security(d, "recorder"); !err.empty()) {
    std::fprintf(stderr, "tandem record: %s\n", err.c_str());
    return 2;
  }
  // Lockstep runs as fast as the machine allows and every tick must reach the file: the recorder is woken
  // ahead of the busy module processes (nice -10, where permitted). In real time the per-tick processes run
  // SCHED_FIFO above it, and it stays at normal priority so as not to take their time.
  if (d.timing == "lockstep" && ::setpriority(PRIO_PROCESS, 0, -10) != 0 && !attached) {
    std::printf("tandem record: note: cannot raise the recorder's priority (%s); a loaded machine may make it miss "
                "ticks, which it reports as gaps\n", std::strerror(errno));
  }
  // The participant outlives the recorder's readers (declared first, destroyed last); it is made before the
  // recorder truncates the file, so that a domain it cannot join leaves an earlier recording alone.
  std::unique_ptr<bus::Participant> part;
  std::unique_ptr<Recorder> rec;
  std::unique_ptr<runtime::StatusPublisher> status_pub;
  try {
    part = std::make_unique<bus::Participant>(d.domain_id, "recorder/" + d.name, runtime::transport_of(d));
    rec = std::make_unique<Recorder>(d, file, out, groups);
    rec->start(*part);
    status_pub = std::make_unique<runtime::StatusPublisher>(*part, "recorder", "recorder", "");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem record: %s\n", e.what());
    return 2;
  }
  runtime::StatusPublisher& status = *status_pub;
  status.msg().deployment(d.name);
  status.set(runtime::Lifecycle::Active, "recording to " + out);
  if (!attached) std::printf("tandem record: recording %s (domain %d) to %s; Ctrl-C to stop\n", d.name.c_str(), d.domain_id, out.c_str());
  const auto t0 = Clock::now();
  auto last_status = t0;
  auto launcher_done = Clock::time_point{};
  bool launcher_seen = false;
  while (!g_record_stop) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    rec->poll();
    const auto now = Clock::now();
    if (duration > 0.0 && std::chrono::duration<double>(now - t0).count() >= duration) break;
    if (!attached) {
      const int ls = rec->launcher_state();
      if (ls >= 0) launcher_seen = true;
      if (launcher_seen && ls >= 3 && launcher_done == Clock::time_point{}) launcher_done = now;
      // The launcher finished: the summaries came before its final state; take the stragglers, then stop.
      if (launcher_done != Clock::time_point{} && now - launcher_done > std::chrono::milliseconds(500)) break;
    }
    if (now - last_status > std::chrono::milliseconds(100)) {
      status.publish();
      last_status = now;
    }
  }
  rec->poll();
  status.set(runtime::Lifecycle::Finalized, "recording closed");
  try {
    const std::string account = rec->finish();
    std::printf("tandem record: %s: %s\n", out.c_str(), account.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem record: %s\n", e.what());
    return 1;
  }
  return 0;
}

}  // namespace tandem::cli
