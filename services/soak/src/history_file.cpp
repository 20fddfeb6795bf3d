#include "tandem/soak/history_file.hpp"

#include <cstdio>
#include <fstream>
#include <vector>
#include <stdexcept>

#include "tandem_soak.pb.h"

namespace tandem::soak {
namespace pb = tandem::soak_record;
namespace {

constexpr uint32_t kFormat = 2;

/// The value of E whose name() is `n` (names are stored, not numbers: a reordered enum reads the same).
template <class E>
E by_name(const std::string& n, const char* what) {
  for (int i = 0; i < 64; ++i) {  // the values are 0, 1, ...: name() says "?" past the last
    const E e = static_cast<E>(i);
    const std::string known = name(e);
    if (known == "?") break;
    if (n == known) return e;
  }
  throw std::runtime_error(std::string("an unknown ") + what + " '" + n + "' (a newer build's?)");
}

/// Whether `m` or any message inside it holds a field this build's schema has no place for.
bool has_unknown_fields(const google::protobuf::Message& m) {
  const google::protobuf::Reflection* r = m.GetReflection();
  if (!r->GetUnknownFields(m).empty()) return true;
  std::vector<const google::protobuf::FieldDescriptor*> fields;
  r->ListFields(m, &fields);
  for (const auto* f : fields) {
    if (f->cpp_type() != google::protobuf::FieldDescriptor::CPPTYPE_MESSAGE) continue;
    if (f->is_repeated()) {
      for (int i = 0; i < r->FieldSize(m, f); ++i) {
        if (has_unknown_fields(r->GetRepeatedMessage(m, f, i))) return true;
      }
    } else if (has_unknown_fields(r->GetMessage(m, f))) {
      return true;
    }
  }
  return false;
}

template <class Seq, class Out>
void copy_strings(const Seq& in, Out* out) {
  for (const auto& s : in) out->Add(std::string(s));
}

pb::RunInfo to_pb(const RunInfo& i) {
  pb::RunInfo o;
  o.set_deployment(i.deployment);
  o.set_deployment_file(i.deployment_file);
  o.set_command(i.command);
  o.set_faults_source(i.faults_source);
  o.set_machine(i.machine);
  o.set_timing(i.timing);
  o.set_seed(i.seed);
  o.set_wall_s(i.wall_s);
  o.set_modules(i.modules);
  o.set_processes_seen(i.processes_seen);
  return o;
}

RunInfo from_pb(const pb::RunInfo& i) {
  RunInfo o;
  o.deployment = i.deployment();
  o.deployment_file = i.deployment_file();
  o.command = i.command();
  o.faults_source = i.faults_source();
  o.machine = i.machine();
  o.timing = i.timing();
  o.seed = i.seed();
  o.wall_s = i.wall_s();
  o.modules = i.modules();
  o.processes_seen = i.processes_seen();
  return o;
}

void to_pb(const ModuleSample& s, pb::ModuleSample* o) {
  o->set_t(s.t);
  o->set_tick(s.tick);
  o->set_normal_min(s.normal_min);
  o->set_slips(s.slips);
  o->set_contact_lost(s.contact_lost);
  o->set_late(s.late);
  o->set_failovers(s.failovers);
  o->set_braked(s.braked);
  o->set_hold(s.hold);
  o->set_load_paused(s.load_paused);
  o->set_released(s.released);
  o->set_stop_tick(s.stop_tick);
  o->set_failed(s.failed);
  o->set_world(s.world);
}

ModuleSample from_pb(const pb::ModuleSample& s) {
  ModuleSample o;
  o.t = s.t();
  o.tick = s.tick();
  o.normal_min = s.normal_min();
  o.slips = s.slips();
  o.contact_lost = s.contact_lost();
  o.late = s.late();
  o.failovers = s.failovers();
  o.braked = s.braked();
  o.hold = s.hold();
  o.load_paused = s.load_paused();
  o.released = s.released();
  o.stop_tick = s.stop_tick();
  o.failed = s.failed();
  o.world = s.world();
  return o;
}

void to_pb(const Event& e, pb::Event* o) {
  o->set_t(e.t);
  o->set_type(name(e.type));
  o->set_subject(e.subject);
  o->set_text(e.text);
  for (const auto& [arm, robot] : e.owners) (*o->mutable_owners())[arm] = robot;
  o->set_tick(e.tick);
  o->set_pid(e.pid);
  for (const auto& [arm, ticks] : e.handover) (*o->mutable_handover())[arm] = ticks;
}

Event from_pb(const pb::Event& e) {
  Event o;
  o.t = e.t();
  o.type = by_name<Event::Type>(e.type(), "event type");
  o.subject = e.subject();
  o.text = e.text();
  for (const auto& [arm, robot] : e.owners()) o.owners[arm] = robot;
  o.tick = e.tick();
  o.pid = e.pid();
  for (const auto& [arm, ticks] : e.handover()) o.handover[arm] = ticks;
  return o;
}

void to_pb(const FaultRecord& r, pb::FaultRecord* o) {
  pb::Fault* f = o->mutable_fault();
  f->set_index(r.fault.index);
  f->set_at_s(r.fault.at_s);
  f->set_kind(name(r.fault.kind));
  f->set_target(name(r.fault.target));
  f->set_label(r.fault.label);
  f->set_duration_s(r.fault.duration_s);
  f->set_cores(r.fault.cores);
  f->set_pick(r.fault.pick);
  o->set_t(r.t);
  o->set_label(r.label);
  o->set_module(r.module);
  o->set_pid(r.pid);
  o->set_skipped(r.skipped);
  o->set_note(r.note);
  o->set_end_t(r.end_t);
  o->set_had_standby(r.had_standby);
  o->set_module_tick(r.module_tick);
}

FaultRecord from_pb(const pb::FaultRecord& r) {
  FaultRecord o;
  const pb::Fault& f = r.fault();
  o.fault.index = f.index();
  o.fault.at_s = f.at_s();
  o.fault.kind = by_name<FaultKind>(f.kind(), "fault kind");
  o.fault.target = by_name<Target>(f.target(), "fault target");
  o.fault.label = f.label();
  o.fault.duration_s = f.duration_s();
  o.fault.cores = f.cores();
  o.fault.pick = f.pick();
  o.t = r.t();
  o.label = r.label();
  o.module = r.module();
  o.pid = r.pid();
  o.skipped = r.skipped();
  o.note = r.note();
  o.end_t = r.end_t();
  o.had_standby = r.had_standby();
  o.module_tick = r.module_tick();
  return o;
}

}  // namespace

void save_history(const std::string& path, const RunInfo& info, const History& h) {
  pb::History o;
  o.set_format(kFormat);
  *o.mutable_info() = to_pb(info);
  o.set_duration_s(h.duration_s);
  o.set_stop_s(h.stop_s);
  o.set_realtime(h.realtime);
  for (const auto& [m, v] : h.h_sg) (*o.mutable_h_sg())[m] = v;
  for (const auto& [m, samples] : h.modules) {
    pb::ModuleSamples& out = (*o.mutable_modules())[m];
    for (const auto& s : samples) to_pb(s, out.add_samples());
  }
  for (const auto& [label, spans] : h.heard) {
    pb::Spans& out = (*o.mutable_heard())[label];
    for (const auto& s : spans) {
      pb::Span* x = out.add_spans();
      x->set_start(s.start);
      x->set_end(s.end);
      x->set_pid(s.pid);
    }
  }
  for (const auto& e : h.events) to_pb(e, o.add_events());
  for (const auto& f : h.faults) to_pb(f, o.add_faults());
  for (const auto& r : h.rss) {
    pb::RssSample* x = o.add_rss();
    x->set_t(r.t);
    x->set_label(r.label);
    x->set_pid(r.pid);
    x->set_mib(r.mib);
    x->set_cpu_s(r.cpu_s);
  }
  for (const auto& [t, bytes] : h.log_bytes) {
    pb::LogBytes* x = o.add_log_bytes();
    x->set_t(t);
    x->set_bytes(bytes);
  }
  copy_strings(h.task_names, o.mutable_task_names());
  copy_strings(h.tasks_done, o.mutable_tasks_done());
  copy_strings(h.tasks_done_by, o.mutable_tasks_done_by());
  copy_strings(h.tasks_running, o.mutable_tasks_running());
  o.set_tasks_done_total(h.tasks_done_total);
  copy_strings(h.leftover_processes, o.mutable_leftover_processes());
  copy_strings(h.leftover_shm, o.mutable_leftover_shm());
  o.set_launcher_exit(h.launcher_exit);
  o.set_ended_by_itself(h.ended_by_itself);
  o.set_complete(true);
  // Whole or not at all: written aside, then renamed over `path`.
  const std::string part = path + ".part";
  {
    std::ofstream out(part, std::ios::binary | std::ios::trunc);
    if (!out || !o.SerializeToOstream(&out) || !out.flush()) {
      std::remove(part.c_str());
      throw std::runtime_error("cannot write the soak's history " + part);
    }
  }
  if (std::rename(part.c_str(), path.c_str()) != 0) {
    std::remove(part.c_str());
    throw std::runtime_error("cannot write the soak's history " + path);
  }
}

const char* name(Event::Type t) {
  switch (t) {
    case Event::Type::Owners: return "owners";
    case Event::Type::State: return "state";
    case Event::Type::Serving: return "serving";
    case Event::Type::TaskAssigned: return "task_assigned";
    case Event::Type::TaskDone: return "task_done";
    case Event::Type::QueueBack: return "queue_back";
    case Event::Type::Parked: return "parked";
    case Event::Type::Unparked: return "unparked";
  }
  return "?";
}

void load_history(const std::string& path, RunInfo& info, History& h) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path + " (a soak report directory holds history.pb)");
  pb::History o;
  if (!o.ParseFromIstream(&in)) throw std::runtime_error(path + " is not a soak history (history.pb)");
  if (o.format() != kFormat) {
    throw std::runtime_error(path + ": history format " + std::to_string(o.format()) + "; this build reads format " +
                             std::to_string(kFormat));
  }
  if (!o.complete()) throw std::runtime_error(path + " is cut short (its last field, `complete`, is missing)");
  if (has_unknown_fields(o)) {
    throw std::runtime_error(path + " has fields this build does not know (written by a newer one?): judge it with "
                             "that build");
  }
  History x;
  try {
    x.duration_s = o.duration_s();
    x.stop_s = o.stop_s();
    x.realtime = o.realtime();
    for (const auto& [m, v] : o.h_sg()) x.h_sg[m] = v;
    for (const auto& [m, samples] : o.modules()) {
      auto& out = x.modules[m];
      for (const auto& s : samples.samples()) out.push_back(from_pb(s));
    }
    for (const auto& [label, spans] : o.heard()) {
      auto& out = x.heard[label];
      for (const auto& s : spans.spans()) out.push_back(Span{s.start(), s.end(), s.pid()});
    }
    for (const auto& e : o.events()) x.events.push_back(from_pb(e));
    for (const auto& f : o.faults()) x.faults.push_back(from_pb(f));
    for (const auto& r : o.rss()) x.rss.push_back(RssSample{r.t(), r.label(), r.pid(), r.mib(), r.cpu_s()});
    for (const auto& l : o.log_bytes()) x.log_bytes.emplace_back(l.t(), l.bytes());
    x.task_names.assign(o.task_names().begin(), o.task_names().end());
    x.tasks_done.assign(o.tasks_done().begin(), o.tasks_done().end());
    x.tasks_done_by.assign(o.tasks_done_by().begin(), o.tasks_done_by().end());
    x.tasks_running.assign(o.tasks_running().begin(), o.tasks_running().end());
    x.tasks_done_total = o.tasks_done_total();
    x.leftover_processes.assign(o.leftover_processes().begin(), o.leftover_processes().end());
    x.leftover_shm.assign(o.leftover_shm().begin(), o.leftover_shm().end());
    x.launcher_exit = o.launcher_exit();
    x.ended_by_itself = o.ended_by_itself();
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  info = from_pb(o.info());
  h = std::move(x);
}

}  // namespace tandem::soak
