#include "tandem/view/live_state.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>

#include "tandem/plan/plan.hpp"

namespace tandem::view {

using nlohmann::json;

namespace {

/// "tandem/torque_commands/m1/left" -> "m1/left" (the arm of a per-tick topic), "" for other topics.
std::string arm_of(const std::string& topic, const char* base) {
  const std::string b = std::string(base) + "/";
  return topic.rfind(b, 0) == 0 ? topic.substr(b.size()) : std::string();
}

const char* state_name(uint32_t s) {
  switch (s) {
    case 0:
      return "unconfigured";
    case 1:
      return "inactive";
    case 2:
      return "active";
    case 3:
      return "finalized";
    case 4:
      return "error";
    default:
      return "unknown";
  }
}

const char* arm_state_name(record::ArmState s) {
  switch (s) {
    case record::ARM_SERVED:
      return "served";
    case record::ARM_BRAKED:
      return "braked";
    case record::ARM_BRAKED_LOAD:
      return "braked (load)";
    default:
      return "none";
  }
}

const char* serving_name(record::ServingRole r) {
  switch (r) {
    case record::ROLE_PRIMARY:
      return "primary";
    case record::ROLE_STANDBY:
      return "standby";
    default:
      return "";
  }
}

/// A number JSON can carry (NaN and infinities are not JSON): null otherwise.
json num(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

}  // namespace

int LiveState::owner_strength(const std::string& arm) const {
  const std::string module = arm.substr(0, arm.find('/'));
  const std::string robot = arm.substr(arm.find('/') + 1);
  const auto m = modules_.find(module);
  if (m != modules_.end() && m->second.reported) {
    for (const auto& o : m->second.report.owners()) {
      if ((o.arm() == robot || o.arm() == arm) && o.state() == record::ARM_SERVED) return o.strength();
    }
  }
  const auto a = arms_.find(arm);
  return a == arms_.end() ? 0 : a->second.strongest;
}

void LiveState::on_message(const std::string& topic, const google::protobuf::Message& m, uint64_t now_ns) {
  const google::protobuf::Descriptor* d = m.GetDescriptor();
  if (d == record::TorqueCommand::descriptor()) {
    const auto& c = static_cast<const record::TorqueCommand&>(m);
    const std::string arm = arm_of(topic, "tandem/torque_commands");
    if (arm.empty()) return;
    Arm& a = arms_[arm];
    a.strongest = std::max(a.strongest, c.strength());
    if (c.strength() != owner_strength(arm) || c.leaving()) return;
    const auto k = static_cast<long long>(c.tick());
    if (a.last_point_tick >= 0 && k < a.last_point_tick + o_.plot_every_ticks && k >= a.last_point_tick)
      return;
    a.last_point_tick = k;
    double ep = 0.0;
    for (int i = 0; i < std::min(2, c.e_p_size()); ++i)
      ep += c.e_p(i) * c.e_p(i);  // position error (x, y) [m]
    points_.push_back({arm, c.tick(), static_cast<double>(now_ns) * 1e-9, std::sqrt(ep), c.normal_force()});
    return;
  }
  if (d == record::ProcessStatus::descriptor()) {
    const auto& s = static_cast<const record::ProcessStatus&>(m);
    Proc& p = procs_[s.process_id()];
    p.s = s;
    p.heard_ns = now_ns;
    return;
  }
  if (d == record::WorldReport::descriptor()) {
    const auto& r = static_cast<const record::WorldReport&>(m);
    Module& mod = modules_[r.module_id()];
    mod.report = r;
    mod.reported = true;
    return;
  }
  if (d == record::TaskState::descriptor()) {
    const auto& t = static_cast<const record::TaskState&>(m);
    Module& mod = modules_[t.module_id()];
    mod.task = t;
    mod.tasked = true;
  }
}

std::string LiveState::on_event(const record::Event& e, uint64_t now_ns) {
  std::string text = json{
      {"t", static_cast<double>(now_ns) * 1e-9},
      {"kind", e.kind()},
      {"module", e.module_id()},
      {"subject", e.subject()},
      {"detail", e.detail()},
      {"tick", e.tick()}}.dump();
  events_.push_back(text);
  while (events_.size() > o_.events_kept) events_.pop_front();
  return text;
}

std::string LiveState::plot_json(const std::vector<PlotPoint>& points) {
  json list = json::array();
  for (const auto& p : points) {
    list.push_back({{"arm", p.arm}, {"tick", p.tick}, {"t", p.t}, {"ep", num(p.ep)}, {"hn", num(p.hn)}});
  }
  return json{{"points", list}}.dump();
}

std::string LiveState::state(uint64_t now_ns, const std::map<std::string, uint64_t>& drops) const {
  json procs = json::array();
  for (const auto& [id, p] : procs_) {
    const auto& s = p.s;
    procs.push_back({{"id", id},
                     {"role", s.role()},
                     {"module", s.module_id()},
                     {"state", state_name(s.state())},
                     {"serving", serving_name(s.serving())},
                     {"strength", s.strength()},
                     {"detail", s.detail()},
                     {"pid", s.pid()},
                     {"host", s.host()},
                     {"heard_s_ago", static_cast<double>(now_ns - std::min(now_ns, p.heard_ns)) * 1e-9}});
  }
  json mods = json::array();
  for (const auto& [name, m] : modules_) {
    json owners = json::array();
    for (const auto& o : m.report.owners()) {
      owners.push_back({{"arm", o.arm()},
                        {"state", arm_state_name(o.state())},
                        {"robot", o.robot()},
                        {"strength", o.strength()}});
    }
    const auto h = h_sg_.find(name);
    const double h_sg = h == h_sg_.end() ? 0.0 : h->second;
    json braked = json::array();
    for (const bool b : m.report.braked()) braked.push_back(b);
    mods.push_back(
        {{"name", name},
         {"tick", m.report.tick()},
         {"h_sg", h_sg},
         {"normal_min", num(m.report.normal_min())},
         // No margin before the world has measured a normal force (its minimum is then a huge sentinel, which the
         // page showed as "1e+300 N").
         {"grasp_margin", m.reported && h_sg > 0.0 && m.report.normal_min() < 1e100 ? num(m.report.normal_min() - h_sg)
                                                                                 : json(nullptr)},
         {"braked", braked},
         {"load_paused", m.report.load_paused()},
         {"failed", m.report.failed()},
         {"failure", m.report.failure()},
         {"slips", m.report.slips()},
         {"failovers", m.report.failovers()},
         {"owners", owners},
         {"task", m.tasked ? json{{"id", m.task.task_id()},
                                  {"state", plan::task_state_name(static_cast<uint8_t>(m.task.state()))},
                                  {"done", m.task.tasks_done()}}
                           : json(nullptr)}});
  }
  json d = json::object();
  for (const auto& [topic, n] : drops) d[topic] = n;
  return json{
      {"t", static_cast<double>(now_ns) * 1e-9}, {"processes", procs}, {"modules", mods}, {"drops", d}}
      .dump();
}

std::string LiveState::state_schema() {
  return R"({"type":"object","properties":{"t":{"type":"number"},"processes":{"type":"array","items":{"type":"object"}},)"
         R"("modules":{"type":"array","items":{"type":"object"}},"drops":{"type":"object"}}})";
}
std::string LiveState::plot_schema() {
  return R"({"type":"object","properties":{"points":{"type":"array","items":{"type":"object","properties":{)"
         R"("arm":{"type":"string"},"tick":{"type":"integer"},"t":{"type":"number"},"ep":{"type":"number"},)"
         R"("hn":{"type":"number"}}}}}})";
}
std::string LiveState::event_schema() {
  return R"({"type":"object","properties":{"t":{"type":"number"},"kind":{"type":"string"},"module":{"type":"string"},)"
         R"("subject":{"type":"string"},"detail":{"type":"string"},"tick":{"type":"integer"}}})";
}

}  // namespace tandem::view
