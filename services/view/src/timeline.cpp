#include "tandem/view/timeline.hpp"

#include <google/protobuf/message.h>

#include <algorithm>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "tandem/record/mcap.hpp"

namespace tandem::view {

using nlohmann::json;

Timeline Timeline::from_recording(const std::string& path) {
  Timeline tl;
  std::map<std::string, double> h_sg;
  std::map<uint16_t, std::unique_ptr<google::protobuf::Message>>
      protos;  // per channel: an instance of its type
  std::unique_ptr<LiveState> live;
  bool first = true;
  double next_snapshot = 0.0;
  auto ensure_live = [&] {
    if (!live) live = std::make_unique<LiveState>(h_sg);
  };
  const record::McapInfo info = record::read_mcap(
      path,
      [&](const record::McapMessageView& m) {
        const double t = static_cast<double>(m.log_time) * 1e-9;
        if (first) {
          tl.start_s_ = t;
          next_snapshot = t;
          first = false;
        }
        tl.end_s_ = std::max(tl.end_s_, t);
        ensure_live();
        auto it = protos.find(m.channel->id);
        if (it == protos.end()) {
          // What the page uses, by topic (docs/recording.md has the channels); the rest is skipped.
          const google::protobuf::Descriptor* d = nullptr;
          const std::string& topic = m.channel->topic;
          if (m.channel->message_encoding == "protobuf") {
            if (topic.rfind("tandem/torque_commands/", 0) == 0) d = record::TorqueCommand::descriptor();
            if (topic.rfind("tandem/world_report/", 0) == 0) d = record::WorldReport::descriptor();
            if (topic == "tandem/process_status") d = record::ProcessStatus::descriptor();
            if (topic == "tandem/task_state") d = record::TaskState::descriptor();
            if (topic == "tandem/events") d = record::Event::descriptor();
          }
          std::unique_ptr<google::protobuf::Message> proto;
          if (d != nullptr)
            proto.reset(google::protobuf::MessageFactory::generated_factory()->GetPrototype(d)->New());
          it = protos.emplace(m.channel->id, std::move(proto)).first;
        }
        if (!it->second || !it->second->ParseFromArray(m.data, static_cast<int>(m.size))) return;
        ++tl.messages_;
        if (it->second->GetDescriptor() == record::Event::descriptor()) {
          tl.events_.emplace_back(t,
                                  live->on_event(static_cast<const record::Event&>(*it->second), m.log_time));
        } else {
          live->on_message(m.channel->topic, *it->second, m.log_time);
        }
        for (auto& p : live->take_points()) tl.points_.push_back(std::move(p));
        if (t >= next_snapshot) {
          tl.states_.emplace_back(t, live->state(m.log_time));
          next_snapshot = t + 1.0;
        }
      },
      true);
  for (const auto& md : info.metadata) {
    if (md.name != "deployment") continue;
    const auto name = md.values.find("deployment");
    if (name != md.values.end()) tl.deployment_ = name->second;
    for (const auto& [k, v] : md.values) {
      if (k.rfind("module.", 0) == 0 && k.size() > 5 && k.compare(k.size() - 5, 5, ".h_sg") == 0) {
        h_sg[k.substr(7, k.size() - 12)] = std::stod(v);
      }
    }
  }
  if (first) throw std::runtime_error(path + ": the recording holds no message");
  // The metadata comes at the end of a file: the snapshots are made again with the modules' h_sg in them.
  if (!h_sg.empty()) {
    for (auto& [t, text] : tl.states_) {
      json s = json::parse(text);
      for (auto& m : s["modules"]) {
        const auto h = h_sg.find(m["name"].get<std::string>());
        if (h == h_sg.end()) continue;
        m["h_sg"] = h->second;
        if (m["normal_min"].is_number()) m["grasp_margin"] = m["normal_min"].get<double>() - h->second;
      }
      text = s.dump();
    }
  }
  tl.states_.emplace_back(tl.end_s_, tl.states_.empty() ? std::string("{}") : tl.states_.back().second);
  std::sort(tl.points_.begin(), tl.points_.end(),
            [](const PlotPoint& a, const PlotPoint& b) { return a.t < b.t; });
  // Log times in file order are not sorted across channels (poll-time stamps beside per-tick ones).
  std::stable_sort(tl.events_.begin(), tl.events_.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::stable_sort(tl.states_.begin(), tl.states_.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  return tl;
}

std::string Timeline::at(double t, double window_s) const {
  json out;
  out["t"] = t;
  auto s = std::upper_bound(states_.begin(), states_.end(), t,
                            [](double v, const std::pair<double, std::string>& e) { return v < e.first; });
  out["state"] = s == states_.begin() ? json(nullptr) : json::parse(std::prev(s)->second);
  const auto lo = std::lower_bound(points_.begin(), points_.end(), t - window_s,
                                   [](const PlotPoint& p, double v) { return p.t < v; });
  const auto hi = std::upper_bound(points_.begin(), points_.end(), t,
                                   [](double v, const PlotPoint& p) { return v < p.t; });
  out["points"] = json::parse(LiveState::plot_json({lo, hi}))["points"];
  auto e = std::upper_bound(events_.begin(), events_.end(), t,
                            [](double v, const std::pair<double, std::string>& x) { return v < x.first; });
  json ev = json::array();
  for (auto it = e - std::min<std::ptrdiff_t>(200, e - events_.begin()); it != e; ++it)
    ev.push_back(json::parse(it->second));
  out["events"] = ev;
  return out.dump();
}

std::string Timeline::summary() const {
  return json{{"start", start_s_},          {"end", end_s_},
              {"deployment", deployment_},  {"messages", messages_},
              {"points", points_.size()},   {"events", events_.size()},
              {"snapshots", states_.size()}}
      .dump();
}

}  // namespace tandem::view
