// tandem view: one more participant of a deployment's domain (as the recorder, with the recorder's identity
// when security is on) that serves the page and the Foxglove WebSocket protocol on one port. It reads the
// domain through record::Tap, exactly as `tandem record` does; every DDS topic is a protobuf channel at full
// rate, and the page's own JSON channels (state, decimated plot points, events) come from view::LiveState.
#include "view_command.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "tandem/dds/bus.hpp"
#include "tandem/launcher/spawn.hpp"
#include "tandem/record/recording.hpp"
#include "tandem/record/tap.hpp"
#include "tandem/runtime/args.hpp"
#include "tandem/runtime/deployment.hpp"
#include "tandem/runtime/security.hpp"
#include "tandem/runtime/status.hpp"
#include "tandem/sim/module_setup.hpp"
#include "tandem/sim/scenario_yaml.hpp"
#include "tandem/view/commands.hpp"
#include "tandem/view/live_state.hpp"
#include "tandem/view/server.hpp"
#include "tandem/view/timeline.hpp"

namespace tandem::cli {

namespace bus = tandem::dds;
using Clock = std::chrono::steady_clock;

namespace {

std::atomic<bool> g_view_stop{false};
void on_view_signal(int) {
  g_view_stop = true;
}

struct ViewArgs {
  std::string file, bind = "127.0.0.1", web, token_file;
  int port = 8765;
  double duration = 0.0;
};

/// The deployment's channels: every topic the tap reads (protobuf, the recordings' schemas), then the page's
/// own.
struct Channels {
  std::vector<view::Channel> list;
  std::map<std::string, uint32_t> by_topic;
  uint32_t state = 0, plot = 0, events_json = 0;
  void add(const std::string& topic, const google::protobuf::Descriptor* d) {
    by_topic[topic] = static_cast<uint32_t>(list.size());
    list.push_back({0, topic, "protobuf", d->full_name(), record::file_descriptor_set(d), "protobuf"});
  }
  uint32_t add_json(const std::string& topic, const std::string& name, std::string schema) {
    const auto id = static_cast<uint32_t>(list.size());
    by_topic[topic] = id;
    list.push_back({0, topic, "json", name, std::move(schema), "jsonschema"});
    return id;
  }
};

/// The tap's sink: the page's model, and each message to the clients subscribed to its topic.
class ViewSink : public record::TapSink {
 public:
  ViewSink(view::LiveState& live, view::Server& server, const Channels& ch)
      : live_(live), server_(server), ch_(ch) {}
  void on_message(const std::string& topic, const google::protobuf::Message& m, uint64_t log_ns,
                  uint64_t) override {
    live_.on_message(topic, m, log_ns);
    send(topic, m, log_ns);
  }
  void on_event(const record::Event& e, uint64_t log_ns) override {
    const std::string text = live_.on_event(e, log_ns);
    server_.publish(ch_.events_json, log_ns, text);
    send("tandem/events", e, log_ns);
  }

 private:
  void send(const std::string& topic, const google::protobuf::Message& m, uint64_t log_ns) {
    const auto it = ch_.by_topic.find(topic);
    if (it == ch_.by_topic.end() || !server_.wanted(it->second)) return;  // serialized only for a subscriber
    buf_.clear();
    m.SerializeToString(&buf_);
    server_.publish(it->second, log_ns, buf_);
  }
  view::LiveState& live_;
  view::Server& server_;
  const Channels& ch_;
  std::string buf_;
};

/// The command line, on CLI11 (runtime::parse_args): `tandem help view` prints the same text as --help.
void describe_args(CLI::App& app, ViewArgs& a) {
  app.description(
      "With a recording (tandem record, tandem up --record): the same page over the recorded run, with a time\n"
      "slider (Foxglove Studio opens the .mcap file itself). With a deployment file: joins the deployment's DDS\n"
      "domain as one more participant (read only, as `tandem record`) and serves, on one port, a page of its own\n"
      "at http://ADDRESS:PORT/ and the Foxglove WebSocket protocol (foxglove.websocket.v1, also offered as\n"
      "foxglove.sdk.v1) on the same address: in Foxglove Studio, open a connection to ws://ADDRESS:PORT. Every\n"
      "DDS topic is a protobuf channel (the schemas the recordings embed), at full rate; tandem/view/state,\n"
      "tandem/view/plot (|e_p| and h_n of each arm's serving robot, 50 Hz) and tandem/view/events are the\n"
      "page's JSON channels.");
  app.add_option("source", a.file, "a deployment file, or a recording (.mcap)")->required()->type_name("DEPLOY.yaml|RUN.mcap");
  app.add_option("--port", a.port, "the port (0: any free port, printed)")
      ->check(CLI::Validator(
          [](std::string& v) {
            char* end = nullptr;
            const long p = std::strtol(v.c_str(), &end, 10);
            return v.empty() || *end != '\0' || p < 0 || p > 65535 || (v.size() > 1 && v[0] == '0')
                       ? "'" + v + "' is not a port number 0-65535 (0: any free port)"
                       : std::string();
          },
          ""))
      ->capture_default_str()->type_name("N");
  app.add_option("--bind", a.bind,
                 "the address to listen on (127.0.0.1: this machine only; other addresses expose the\n"
                 "deployment's data to the network)")
      ->capture_default_str()->type_name("ADDR");
  app.add_option("--duration", a.duration, "stop after S seconds (default: until Ctrl-C or SIGTERM)")
      ->check(runtime::seconds_up_to(1e7))->type_name("S");
  app.add_option("--web", a.web, "the page's files (default: share/tandem/view beside the binaries)")->type_name("DIR");
  app.add_option("--token-file", a.token_file,
                 "the token that live commands from other machines must carry (its first line, 16+ characters);\n"
                 "without it a viewer on another address than loopback makes one and prints the page's URL with it")
      ->type_name("F");
  app.footer(
      "Live commands: the page's buttons (down, kill, unplug) run `tandem <command> <deploy.yaml> ...` as the\n"
      "CLI does (with security on, through the cli identity). From this machine they need nothing more, as the\n"
      "CLI does not; from another machine, the token (X-Tandem-Token header; the page takes it from ?token=).\n"
      "\n"
      "Each client has a bounded queue per channel (1000 frames; 64 for the page's state and plot) that drops its\n"
      "oldest frame when the client falls behind and counts it; the page shows the drops. A slow client never\n"
      "slows the deployment. Exit: 0 stopped, 2 bad command line, deployment, or a port it cannot listen on.");
}

int parse_view_args(const std::vector<std::string>& args, ViewArgs& a) {
  CLI::App app("", "tandem view");
  describe_args(app, a);
  return runtime::parse_args(app, args);
}

/// The tap's configuration and the channels of deployment `d`; the safe-grasp force of each module.
void describe(const runtime::Deployment& d, record::TapConfig& tc, Channels& ch,
              std::map<std::string, double>& h_sg) {
  tc.deployment = d.name;
  tc.realtime = d.timing == "realtime";
  tc.groups = {std::begin(runtime::kRecordGroups), std::end(runtime::kRecordGroups)};
  for (const auto& m : d.modules) {
    const sim::Scenario sc = sim::load_scenario(m.scenario);
    for (const auto& c : sc.cases) {
      if (c.name == m.case_name) h_sg[m.name] = sim::make_module(sc, c).safe_grasp_force;
    }
    tc.modules.push_back(m.name);
    for (int j = 0; j < 2; ++j) {
      const std::string arm = m.name + "/" + sc.robots[j].name;
      tc.arms.push_back(arm);
      ch.add(bus::arm_topic(bus::kSensorsTopic, arm), record::ArmSensors::descriptor());
      ch.add(bus::arm_topic(bus::kTorquesTopic, arm), record::TorqueCommand::descriptor());
    }
    ch.add(bus::module_topic(bus::kWorldReportTopic, m.name), record::WorldReport::descriptor());
    ch.add(bus::module_topic(bus::kSupervisorPlanTopic, m.name), record::SupervisorPlan::descriptor());
  }
  ch.add(bus::kStatusTopic, record::ProcessStatus::descriptor());
  ch.add(bus::kTaskAssignmentTopic, record::TaskAssignment::descriptor());
  ch.add(bus::kTaskStateTopic, record::TaskState::descriptor());
  ch.add(bus::kRobotSummaryTopic, record::RobotSummary::descriptor());
  ch.add(bus::kWorldSummaryTopic, record::WorldSummary::descriptor());
  ch.add(bus::kControlTopic, record::ControlRequest::descriptor());
  ch.add("tandem/events", record::Event::descriptor());
  ch.state = ch.add_json(view::LiveState::kStateTopic, "tandem.view.State", view::LiveState::state_schema());
  ch.plot = ch.add_json(view::LiveState::kPlotTopic, "tandem.view.Plot", view::LiveState::plot_schema());
  ch.events_json =
      ch.add_json(view::LiveState::kEventsTopic, "tandem.view.Event", view::LiveState::event_schema());
}

/// Until stopped: the keyed topics every 20 ms, plot points every 50 ms, the state every 250 ms, time every
/// 100 ms.
void serve(record::Tap& tap, view::LiveState& live, view::Server& server, const Channels& ch,
           runtime::StatusPublisher& status, double duration) {
  const auto t0 = Clock::now();
  auto last_plot = t0, last_state = t0, last_time = t0;
  while (!g_view_stop) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    tap.poll();
    const auto now = Clock::now();
    const uint64_t ns = record::now_ns();
    if (now - last_plot >= std::chrono::milliseconds(50)) {
      std::string plot;
      tap.locked([&] { plot = live.take_plot(); });
      if (!plot.empty()) server.publish(ch.plot, ns, plot);
      last_plot = now;
    }
    if (now - last_time >= std::chrono::milliseconds(100)) {
      server.broadcast_time(ns);
      status.publish();
      last_time = now;
    }
    if (now - last_state >= std::chrono::milliseconds(250)) {
      std::string state;
      std::vector<std::string> history;
      const auto drops = server.drops();
      tap.locked([&] {
        state = live.state(ns, drops);
        history = live.recent_events();
      });
      server.publish(ch.state, ns, state);
      server.set_history(ch.events_json, std::move(history));
      last_state = now;
    }
    if (duration > 0.0 && now - t0 >= std::chrono::duration<double>(duration)) break;
  }
}

/// Runs `tandem <args>` (this program, from its own directory) as a user would, and returns its exit code, with what
/// it printed (both streams, at most 4 kB) in `out`. Killed after 30 s (the CLI itself gives up within 15 s).
int run_cli(const std::vector<std::string>& args, std::string& out) {
  int fd[2];
  if (::pipe2(fd, O_CLOEXEC) != 0) {  // (dup2 gives the child's stdout and stderr without the flag)
    out = std::string("cannot make a pipe: ") + std::strerror(errno);
    return 1;
  }
  const std::string exe = launcher::self_dir() + "/tandem";
  std::vector<char*> argv{const_cast<char*>(exe.c_str())};
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::dup2(fd[1], 1);
    ::dup2(fd[1], 2);
    ::close(fd[0]);
    ::close(fd[1]);
    ::execv(exe.c_str(), argv.data());
    ::_exit(127);
  }
  ::close(fd[1]);
  if (pid < 0) {
    ::close(fd[0]);
    out = std::string("cannot start tandem: ") + std::strerror(errno);
    return 1;
  }
  const auto t0 = Clock::now();
  char buf[512];
  for (;;) {
    pollfd p{fd[0], POLLIN, 0};
    const int r = ::poll(&p, 1, 200);
    if (r > 0) {
      const ssize_t n = ::read(fd[0], buf, sizeof buf);
      if (n <= 0) break;
      if (out.size() < 4096) out.append(buf, static_cast<size_t>(n));
    }
    if (Clock::now() - t0 > std::chrono::seconds(30)) {
      ::kill(pid, SIGKILL);
      out += "\n(no answer within 30 s; stopped)";
      break;
    }
  }
  ::close(fd[0]);
  int st = 0;
  ::waitpid(pid, &st, 0);
  while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
  return WIFEXITED(st) ? WEXITSTATUS(st) : 1;
}

/// The token for live commands from other machines: read from --token-file, or made afresh when the viewer listens
/// on another address than loopback (printed with the URL), else none (this machine only). False (said) on a bad
/// file.
bool command_token(const ViewArgs& a, std::string& token) {
  if (!a.token_file.empty()) {
    std::ifstream f(a.token_file);
    if (!(f >> token) || token.size() < 16) {
      std::fprintf(stderr, "tandem view: --token-file %s: expected a token of at least 16 characters on its first line\n",
                   a.token_file.c_str());
      return false;
    }
    return true;
  }
  token = view::is_loopback(a.bind) ? "" : view::make_token();
  return true;
}

/// POST /api/command: a live command from the page, carried out by the CLI (view::LiveCommand), one at a time.
void serve_commands(view::Server& server, const std::string& file, const std::string& token, const std::string& bind) {
  static std::mutex one_at_a_time;
  server.set_post("/api/command", [file, token, bind, &server](const view::Server::PostIn& in) {
    view::Server::PostOut o;
    std::string why = view::refusal(in.remote, in.token, token);
    if (why.empty()) why = view::browser_refusal(in.content_type, in.origin, in.host, bind, server.port());
    if (!why.empty()) {
      o.status = 403;
      o.json = view::answer_json(false, why);
      return o;
    }
    view::LiveCommand c;
    try {
      c = view::parse_live_command(in.body);
    } catch (const std::exception& e) {
      o.status = 400;
      o.json = view::answer_json(false, e.what());
      return o;
    }
    std::lock_guard<std::mutex> lock(one_at_a_time);
    std::string text;
    const int rc = run_cli(view::cli_args(c, file), text);
    std::printf("tandem view: live command from %s: %s %s -> %s\n", in.remote.c_str(), c.verb.c_str(), c.target.c_str(),
                rc == 0 ? "done" : "refused or failed");
    std::fflush(stdout);
    o.json = view::answer_json(rc == 0, text);
    return o;
  });
}

/// The server's options from the command line: address, port, the page's files, and what serverInfo says.
view::Server::Options server_options(const ViewArgs& a, std::string name,
                                     std::vector<std::pair<std::string, std::string>> metadata) {
  view::Server::Options so;
  so.bind = a.bind;
  so.port = a.port;
  so.web_dir = a.web.empty() ? launcher::self_dir() + "/../share/tandem/view" : a.web;
  so.name = std::move(name);
  so.metadata = std::move(metadata);
  return so;
}

/// `tandem view run.mcap`: the same page over a recording, with a time slider (GET /recording,
/// /recording/at?t=S).
int view_recording(const ViewArgs& a) {
  view::Timeline tl;
  try {
    tl = view::Timeline::from_recording(a.file);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem view: %s\n", e.what());
    return 2;
  }
  view::Server server(server_options(a, "tandem " + a.file, {{"source", "recording"}}), {});
  server.set_json("/recording", [&tl](const std::string&) { return tl.summary(); });
  server.set_json("/recording/at", [&tl](const std::string& query) {
    // ?t=SECONDS (log time), the only parameter
    const std::string key = "t=";
    size_t at = query.rfind(key, 0) == 0 ? 0 : query.find("&" + key);
    if (at == std::string::npos) throw std::runtime_error("/recording/at needs ?t=SECONDS (log time)");
    at += query[at] == '&' ? key.size() + 1 : key.size();
    char* end = nullptr;
    const double t = std::strtod(query.c_str() + at, &end);
    if (end == query.c_str() + at || !std::isfinite(t)) throw std::runtime_error("/recording/at: t is not a number");
    return tl.at(t);
  });
  std::string err;
  if (!server.start(err)) {
    std::fprintf(stderr, "tandem view: %s\n", err.c_str());
    return 2;
  }
  std::printf("tandem view: %s (%.1f s, %zu plot points, %zu events) at %s\n", a.file.c_str(),
              tl.end_s() - tl.start_s(), tl.points(), tl.events(), server.url().c_str());
  std::fflush(stdout);
  const auto t0 = Clock::now();
  while (!g_view_stop &&
         !(a.duration > 0.0 && Clock::now() - t0 >= std::chrono::duration<double>(a.duration))) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  server.stop();
  return 0;
}

}  // namespace

void view_usage(std::FILE* f) {
  ViewArgs a;
  CLI::App app("", "tandem view");
  describe_args(app, a);
  std::fputs(app.help().c_str(), f);
}

int view_command(const std::vector<std::string>& args) {
  ViewArgs a;
  if (const int rc = parse_view_args(args, a); rc >= 0) return rc;
  // Never ahead of the deployment: a viewer started by `tandem up --view` inherits the launcher's raised niceness
  // (launcher::kServiceNice), which is for the control plane; before any thread exists, so all inherit 0.
  (void)::setpriority(PRIO_PROCESS, 0, 0);
  struct sigaction sa {};
  sa.sa_handler = on_view_signal;
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
  if (a.file.size() > 5 && a.file.compare(a.file.size() - 5, 5, ".mcap") == 0) return view_recording(a);
  runtime::Deployment d;
  record::TapConfig tc;
  Channels ch;
  std::map<std::string, double> h_sg;
  try {
    d = runtime::load_deployment(a.file);
    describe(d, tc, ch, h_sg);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem view: %s\n", e.what());
    return 2;
  }
  runtime::use_discovery(d);
  if (const std::string err = runtime::use_security(d, "recorder"); !err.empty()) {
    std::fprintf(stderr, "tandem view: %s\n", err.c_str());
    return 2;
  }
  view::Server server(server_options(a, "tandem " + d.name,
                                     {{"deployment", d.name}, {"timing", d.timing}, {"domain", std::to_string(d.domain_id)}}),
                      ch.list);
  server.set_json("/recording",
                  [](const std::string&) { return std::string("null"); });  // the page: live mode
  std::string token;
  if (!command_token(a, token)) return 2;
  serve_commands(server, a.file, token, a.bind);
  view::LiveState live(h_sg);
  ViewSink sink(live, server, ch);
  std::unique_ptr<bus::Participant> part;
  std::unique_ptr<record::Tap> tap;
  std::unique_ptr<runtime::StatusPublisher> status;
  std::string err;
  try {
    part = std::make_unique<bus::Participant>(d.domain_id, "viewer/" + d.name, runtime::transport_of(d));
    if (!server.start(err)) throw std::runtime_error(err);
    tap = std::make_unique<record::Tap>(tc, sink);
    tap->start(*part);
    status = std::make_unique<runtime::StatusPublisher>(*part, "viewer", "viewer", "");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem view: %s\n", e.what());
    return 2;
  }
  status->msg().deployment(d.name);
  status->set(runtime::Lifecycle::Active, "serving " + server.url());
  std::printf("tandem view: %s (domain %d) at %s (Foxglove: ws://%s:%d)\n", d.name.c_str(), d.domain_id,
              server.url().c_str(), a.bind.c_str(), server.port());
  if (!token.empty() && a.token_file.empty()) {
    std::printf("tandem view: live commands from other machines need the token: open %s?token=%s\n",
                server.url().c_str(), token.c_str());
  }
  std::fflush(stdout);
  serve(*tap, live, server, ch, *status, a.duration);
  tap->close();
  server.stop();
  status->set(runtime::Lifecycle::Finalized, "stopped");
  std::printf("tandem view: stopped\n");
  return 0;
}

}  // namespace tandem::cli
