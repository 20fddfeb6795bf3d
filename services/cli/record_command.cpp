// tandem record: a DDS participant of a deployment's domain that writes the chosen topics to an MCAP file
// with Protobuf messages (services/record, docs/recording.md). Started by `tandem up` when the deployment has
// `record:` (or `tandem up --record FILE`), or by hand beside a running deployment. It only reads: per-tick
// samples arrive by the same delivery the robots use (dds::shares_data), on the recorder's own listener threads,
// and are converted and appended to an in-memory chunk (written out every 1 MiB or second).
#include "record_command.hpp"

#include <sys/resource.h>
#include <tandemPubSubTypes.h>
#include <tandem_record.pb.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <functional>
#include <iterator>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "tandem/dds/bus.hpp"
#include "tandem/record/recording.hpp"
#include "tandem/record/tap.hpp"
#include "tandem/runtime/args.hpp"
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
void on_record_signal(int) {
  g_record_stop = true;
}

const std::set<std::string> kGroups(std::begin(runtime::kRecordGroups), std::end(runtime::kRecordGroups));

/// The recorder: the tap (record::Tap) into one MCAP file.
class Recorder : public record::TapSink {
 public:
  Recorder(const runtime::Deployment& d, const std::string& file, const std::string& out,
           const std::set<std::string>& groups)
      : w_(out) {
    record::TapConfig tc;
    tc.deployment = d.name;
    tc.realtime = d.timing == "realtime";
    tc.groups = groups;
    std::map<std::string, std::string> meta{{"deployment", d.name},
                                            {"deployment_file", file},
                                            {"timing", d.timing},
                                            {"domain", std::to_string(d.domain_id)},
                                            {"transport", d.transport},
                                            {"modules", ""},
                                            {"topics", ""}};
    for (const auto& g : groups) meta["topics"] += (meta["topics"].empty() ? "" : ",") + g;
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
      meta["module." + m.name + ".arms"] =
          m.name + "/" + sc.robots[0].name + "," + m.name + "/" + sc.robots[1].name;
      meta["module." + m.name + ".scenario"] = m.scenario;
      meta["module." + m.name + ".case"] = m.case_name;
      tc.modules.push_back(m.name);
      for (int j = 0; j < 2; ++j) tc.arms.push_back(m.name + "/" + sc.robots[j].name);
    }
    w_.metadata("deployment", meta);
    events_ = w_.channel("tandem/events", pb::Event::descriptor());
    // The per-tick channels first, in arm order, with the arm as metadata (the rest are made on first use).
    if (groups.count("ticks") != 0) {
      for (const auto& arm : tc.arms) {
        (void)w_.channel(bus::arm_topic(bus::kSensorsTopic, arm), pb::ArmSensors::descriptor(),
                         {{"arm", arm}});
        (void)w_.channel(bus::arm_topic(bus::kTorquesTopic, arm), pb::TorqueCommand::descriptor(),
                         {{"arm", arm}});
      }
    }
    tap_ = std::make_unique<record::Tap>(std::move(tc), *this);
  }

  void start(bus::Participant& part) { tap_->start(part); }

  /// Takes what the keyed topics hold (called every 20 ms by the main loop) and writes the file out every
  /// second.
  void poll() {
    tap_->poll();
    tap_->locked([this] {
      if (Clock::now() - last_flush_ > std::chrono::seconds(1)) {  // a crash loses at most a second
        w_.flush();
        last_flush_ = Clock::now();
      }
    });
  }

  int launcher_state() const { return tap_->launcher_state(); }

  /// Closes the file; returns a one-line account.
  std::string finish() {
    const std::map<std::string, record::ArmTapStats> arms = tap_->stats();
    tap_->close();
    uint64_t gaps = 0, gap_ticks = 0, per_tick = 0;
    std::map<std::string, std::string> stats;
    for (const auto& [arm, a] : arms) {
      gaps += a.gaps;
      gap_ticks += a.missed_ticks;
      per_tick += a.sensor_samples + a.torque_samples;
      stats["arm." + arm + ".sensor_samples"] = std::to_string(a.sensor_samples);
      stats["arm." + arm + ".torque_samples"] = std::to_string(a.torque_samples);
      stats["arm." + arm + ".missed_ticks"] = std::to_string(a.missed_ticks);
    }
    stats["messages"] = std::to_string(w_.messages());
    stats["gaps"] = std::to_string(gaps);
    stats["missed_ticks"] = std::to_string(gap_ticks);
    w_.metadata("recorder", stats);
    w_.close();
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "%llu messages (%llu per-tick samples), %.1f MiB; %llu tick(s) missed in %llu gap(s)",
                  static_cast<unsigned long long>(w_.messages()), static_cast<unsigned long long>(per_tick),
                  static_cast<double>(w_.bytes()) / (1024.0 * 1024.0),
                  static_cast<unsigned long long>(gap_ticks), static_cast<unsigned long long>(gaps));
    return buf;
  }

 private:
  // record::TapSink: called under the tap's mutex.
  void on_message(const std::string& topic, const google::protobuf::Message& m, uint64_t log_ns,
                  uint64_t publish_ns) override {
    w_.write(w_.channel(topic, m.GetDescriptor()), m, log_ns, publish_ns);
  }
  void on_event(const pb::Event& e, uint64_t log_ns) override { w_.write(events_, e, log_ns); }

  pb::RecordingWriter w_;
  uint16_t events_ = 0;
  Clock::time_point last_flush_ = Clock::now();
  std::unique_ptr<record::Tap> tap_;  ///< last: destroyed (readers first) before the writer
};

}  // namespace

namespace {

struct RecordArgs {
  std::string file, out, topics = "all";
  double duration = 0.0;
  std::set<std::string> groups = kGroups;
  bool attached = false;
};

/// --topics: a comma-separated list of groups ("all" for every one); the message names an unknown group.
std::string parse_groups(const std::string& list, std::set<std::string>& groups) {
  groups.clear();
  std::stringstream ss(list);
  std::string g;
  while (std::getline(ss, g, ',')) {
    if (g == "all") {
      groups = kGroups;
    } else if (kGroups.count(g) == 0) {
      return "unknown topic group '" + g + "'; accepted: all, ticks, world, status, tasks, summaries, control, events";
    } else {
      groups.insert(g);
    }
  }
  return groups.empty() ? "names no group" : "";
}

/// The command line, on CLI11 (runtime::parse_args): `tandem help record` prints the same text as --help.
void describe(CLI::App& app, RecordArgs& o) {
  app.description(
      "Joins the deployment's DDS domain as its own participant and writes what it hears to an MCAP file\n"
      "with Protobuf messages (schema idl/tandem_record.proto; each schema record holds the FileDescriptorSet,\n"
      "so Foxglove Studio, the mcap CLI or any MCAP library decodes it). Start it beside a running deployment,\n"
      "or let `tandem up` start it: `record: FILE` in the deployment, or `tandem up --record FILE`.");
  app.add_option("deploy", o.file, "the deployment file")->required()->type_name("DEPLOY.yaml");
  app.add_option("-o,--out", o.out, "the recording to write (overwritten)")->required()->type_name("FILE.mcap");
  app.add_option("--topics", o.topics,
                 "comma-separated groups (default: all):\n"
                 "  ticks      arm sensors and torque commands of every arm, every tick\n"
                 "  world      the worlds' reports (brakes, holds, owners, counters), every 10 ticks\n"
                 "  status     every process's status (about every 100 ms)\n"
                 "  tasks      task assignments, task states, the supervisors' plans\n"
                 "  summaries  robot and world summaries at the end of a run\n"
                 "  control    control requests (down, kill, plug, unplug, pause, ...)\n"
                 "  events     lifecycle changes, failovers/takeovers, brakes, pauses, tasks, gaps")
      ->check(CLI::Validator([&o](std::string& v) { return parse_groups(v, o.groups); }, ""))
      ->type_name("LIST");
  app.add_option("--duration", o.duration,
                 "stop after S seconds (default: until Ctrl-C, SIGTERM, or the deployment's launcher finishes)")
      ->check(runtime::seconds_up_to(1e7))->type_name("S");
  app.add_flag("--attached", o.attached, "started by `tandem up`: stop only on SIGTERM (the launcher stops it last)");
  app.footer(
      "Per-tick topics are read with the robots' QoS: in lockstep nothing is lost (the world waits for the\n"
      "recorder to match before its first tick); in real time samples are best effort and a tick the recorder\n"
      "did not get is logged as a 'gap' event. Use `tandem report FILE.mcap -o DIR` for plots.\n"
      "Exit: 0 written, 1 the file could not be written completely, 2 bad command line or deployment.");
}

}  // namespace

void record_usage(std::FILE* f) {
  RecordArgs o;
  CLI::App app("", "tandem record");
  describe(app, o);
  std::fputs(app.help().c_str(), f);
}

namespace {

/// Signals, discovery, security and priority for a recorder of `d`; -1 to go on, else the exit code.
int prepare_recorder(const runtime::Deployment& d, bool attached) {
  struct sigaction sa {};
  sa.sa_handler = on_record_signal;
  ::sigaction(SIGTERM, &sa, nullptr);
  // Started by the launcher, it shares the terminal's process group: Ctrl-C is for the launcher, which stops
  // the recorder last (SIGTERM), after the modules' final summaries.
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
  // SCHED_FIFO above it whatever its niceness (started by `tandem up`, it has the launcher's, -10, as the
  // control plane has; by hand, the shell's).
  if (d.timing == "lockstep" && ::setpriority(PRIO_PROCESS, 0, -10) != 0 && !attached) {
    std::printf(
        "tandem record: note: cannot raise the recorder's priority (%s); a loaded machine may make it miss "
        "ticks, which it reports as gaps\n",
        std::strerror(errno));
  }
  return -1;
}

/// Records until stopped, the duration is over, or (by hand) the deployment's launcher has finished.
void record_until_done(Recorder& rec, runtime::StatusPublisher& status, const RecordArgs& o) {
  const auto t0 = Clock::now();
  auto last_status = t0;
  auto launcher_done = Clock::time_point{};
  bool launcher_seen = false;
  while (!g_record_stop) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    rec.poll();
    const auto now = Clock::now();
    if (o.duration > 0.0 && std::chrono::duration<double>(now - t0).count() >= o.duration) break;
    if (!o.attached) {
      const int ls = rec.launcher_state();
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
  rec.poll();
}

}  // namespace

int record_command(const std::vector<std::string>& args) {
  RecordArgs o;
  CLI::App app("", "tandem record");
  describe(app, o);
  if (const int code = runtime::parse_args(app, args); code >= 0) return code;
  runtime::Deployment d;
  try {
    d = runtime::load_deployment(o.file);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem record: %s\n", e.what());
    return 2;
  }
  if (const int code = prepare_recorder(d, o.attached); code >= 0) return code;
  // The participant outlives the recorder's readers (declared first, destroyed last); it is made before the
  // recorder truncates the file, so that a domain it cannot join leaves an earlier recording alone.
  std::unique_ptr<bus::Participant> part;
  std::unique_ptr<Recorder> rec;
  std::unique_ptr<runtime::StatusPublisher> status;
  try {
    part = std::make_unique<bus::Participant>(d.domain_id, "recorder/" + d.name, runtime::transport_of(d));
    rec = std::make_unique<Recorder>(d, o.file, o.out, o.groups);
    rec->start(*part);
    status = std::make_unique<runtime::StatusPublisher>(*part, "recorder", "recorder", "");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem record: %s\n", e.what());
    return 2;
  }
  status->msg().deployment(d.name);
  status->set(runtime::Lifecycle::Active, "recording to " + o.out);
  if (!o.attached) {
    std::printf("tandem record: recording %s (domain %d) to %s; Ctrl-C to stop\n", d.name.c_str(), d.domain_id,
                o.out.c_str());
  }
  record_until_done(*rec, *status, o);
  status->set(runtime::Lifecycle::Finalized, "recording closed");
  try {
    const std::string account = rec->finish();
    std::printf("tandem record: %s: %s\n", o.out.c_str(), account.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem record: %s\n", e.what());
    return 1;
  }
  return 0;
}

}  // namespace tandem::cli
