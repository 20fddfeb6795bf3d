// What the viewer's page shows, from the tap's messages (idl/tandem_record.proto types): the processes, the
// modules (task, grasp margin, brakes, load pause, who serves each arm), per-arm plot points of |e_p| and h_n
// decimated for the page, and the events. It turns them into the JSON of the viewer's own channels
// (tandem/view/state, tandem/view/plot, tandem/view/events), which Foxglove Studio can read as well. No
// socket, no DDS, no clock.
#pragma once

#include <google/protobuf/message.h>
#include <tandem_record.pb.h>

#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace tandem::view {

/// One plot point of an arm: its serving robot's |e_p| (x, y) [m] and h_n [N] at a tick, at log time t [s].
struct PlotPoint {
  std::string arm;
  uint64_t tick = 0;
  double t = 0.0, ep = 0.0, hn = 0.0;
};

class LiveState {
 public:
  struct Options {
    /// One plot point per arm every this many ticks (20: 50 Hz at the paper's 1 kHz), from the robot that
    /// serves the arm (the world's owners), else the strongest one heard.
    int plot_every_ticks = 20;
    size_t events_kept = 200;  ///< the newest events, for a page that opens late
  };
  /// `h_sg`: the safe-grasp force of each module [N] (the page draws h_n against it).
  explicit LiveState(std::map<std::string, double> h_sg) : LiveState(std::move(h_sg), Options{}) {}
  LiveState(std::map<std::string, double> h_sg, Options o) : h_sg_(std::move(h_sg)), o_(o) {}

  /// A tap message on DDS topic `topic`.
  void on_message(const std::string& topic, const google::protobuf::Message& m, uint64_t now_ns);
  /// A derived event; returns its JSON (the events channel's message).
  std::string on_event(const record::Event& e, uint64_t now_ns);

  /// The plot points since the last call, as {"points": [{"arm","tick","t","ep","hn"}]}; "" if none.
  std::string take_plot() { return points_.empty() ? std::string() : plot_json(take_points()); }
  std::vector<PlotPoint> take_points() { return std::exchange(points_, {}); }
  static std::string plot_json(const std::vector<PlotPoint>& points);
  /// Processes, modules, and the drops each channel counted (`drops`: channel topic -> frames dropped).
  std::string state(uint64_t now_ns, const std::map<std::string, uint64_t>& drops = {}) const;
  /// The newest events (oldest first), each as its JSON: what a page that opens late shows first.
  std::vector<std::string> recent_events() const { return {events_.begin(), events_.end()}; }

  size_t processes() const { return procs_.size(); }
  size_t pending_points() const { return points_.size(); }

  static constexpr const char* kStateTopic = "tandem/view/state";
  static constexpr const char* kPlotTopic = "tandem/view/plot";
  static constexpr const char* kEventsTopic = "tandem/view/events";
  /// JSON Schemas of the three channels (for Foxglove's advertise).
  static std::string state_schema();
  static std::string plot_schema();
  static std::string event_schema();

 private:
  struct Proc {
    record::ProcessStatus s;
    uint64_t heard_ns = 0;
  };
  struct Module {
    record::WorldReport report;
    bool reported = false;
    record::TaskState task;
    bool tasked = false;
  };
  struct Arm {
    long long last_point_tick = -1;
    int strongest = 0;  ///< the strongest strength heard (fallback owner)
  };
  int owner_strength(const std::string& arm) const;

  std::map<std::string, double> h_sg_;
  Options o_;
  std::map<std::string, Proc> procs_;
  std::map<std::string, Module> modules_;
  std::map<std::string, Arm> arms_;
  std::vector<PlotPoint> points_;
  std::deque<std::string> events_;
};

}  // namespace tandem::view
