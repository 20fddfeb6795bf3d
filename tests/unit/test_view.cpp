// tandem view's pure parts: the Foxglove protocol frames (checked byte for byte against the spec's layout and
// with an independent JSON reading), the bounded client outbox (drops oldest per channel, never starves a
// rare channel), and the page's model from recording messages.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

#include "tandem/record/recording.hpp"
#include "tandem/view/foxglove.hpp"
#include "tandem/view/commands.hpp"
#include "tandem/view/live_state.hpp"
#include "tandem/view/outbox.hpp"
#include "tandem/view/timeline.hpp"

using namespace tandem;
using nlohmann::json;

namespace {
uint64_t le(const std::string& s, size_t at, int bytes) {
  uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | static_cast<uint8_t>(s[at + static_cast<size_t>(i)]);
  return v;
}
}  // namespace

TEST_CASE("view: base64 as RFC 4648 gives it") {
  CHECK(view::base64("") == "");
  CHECK(view::base64("f") == "Zg==");
  CHECK(view::base64("fo") == "Zm8=");
  CHECK(view::base64("foo") == "Zm9v");
  CHECK(view::base64("foobar") == "Zm9vYmFy");
  CHECK(view::base64(std::string("\x00\xff\x10", 3)) == "AP8Q");
}

TEST_CASE("view: Foxglove frames have the spec's layout") {
  const std::string m = view::message_data(0x01020304U, 0x1122334455667788ULL, "abc");
  REQUIRE(m.size() == 1 + 4 + 8 + 3);
  CHECK(static_cast<uint8_t>(m[0]) == 0x01);
  CHECK(le(m, 1, 4) == 0x01020304U);
  CHECK(le(m, 5, 8) == 0x1122334455667788ULL);
  CHECK(m.substr(13) == "abc");
  const std::string t = view::time_frame(42);
  REQUIRE(t.size() == 9);
  CHECK(static_cast<uint8_t>(t[0]) == 0x02);
  CHECK(le(t, 1, 8) == 42);

  const json info = json::parse(view::server_info("tandem soak-small", "s1", {{"deployment", "soak-small"}}));
  CHECK(info["op"] == "serverInfo");
  CHECK(info["sessionId"] == "s1");
  CHECK(info["capabilities"] == json::array({"time"}));
  CHECK(info["metadata"]["deployment"] == "soak-small");

  view::Channel pb{7,
                   "tandem/arm_sensors/m1/left",
                   "protobuf",
                   "tandem.record.ArmSensors",
                   std::string("\x0a\x01", 2),
                   "protobuf"};
  view::Channel js{8,           "tandem/view/state", "json", "tandem.view.State", "{\"type\":\"object\"}",
                   "jsonschema"};
  const json adv = json::parse(view::advertise({pb, js}));
  REQUIRE(adv["channels"].size() == 2);
  CHECK(adv["channels"][0]["id"] == 7);
  CHECK(adv["channels"][0]["schema"] == "CgE=");  // base64 of the binary descriptor set
  CHECK(adv["channels"][0]["schemaEncoding"] == "protobuf");
  CHECK(adv["channels"][1]["schema"] == "{\"type\":\"object\"}");  // JSON Schema as text
  const json st = json::parse(view::status(1, "dropped 3 frames"));
  CHECK(st["op"] == "status");
  CHECK(st["level"] == 1);
}

TEST_CASE("view: client requests are parsed, and bad ones get a reason, not a crash") {
  auto op = view::parse_client_op(
      R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":3},{"id":2,"channelId":0}]})");
  REQUIRE(op.kind == view::ClientOp::Kind::Subscribe);
  REQUIRE(op.subscriptions.size() == 2);
  CHECK(op.subscriptions[0] == std::make_pair(1U, 3U));
  op = view::parse_client_op(R"({"op":"unsubscribe","subscriptionIds":[1,2]})");
  REQUIRE(op.kind == view::ClientOp::Kind::Unsubscribe);
  CHECK(op.unsubscribe == std::vector<uint32_t>{1, 2});
  CHECK(view::parse_client_op("{not json").kind == view::ClientOp::Kind::Bad);
  CHECK(view::parse_client_op(R"({"op":"subscribe","subscriptions":[{"id":-1,"channelId":3}]})").kind ==
        view::ClientOp::Kind::Bad);
  CHECK(
      view::parse_client_op(R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":4294967296}]})").kind ==
      view::ClientOp::Kind::Bad);
  const auto adv = view::parse_client_op(R"({"op":"advertise","channels":[]})");
  CHECK(adv.kind == view::ClientOp::Kind::Ignored);
  CHECK_THAT(adv.error, Catch::Contains("advertise") && Catch::Contains("not supported"));
}

TEST_CASE("view: an outbox drops a busy channel's oldest frames and still sends the rare channel's at once") {
  view::Outbox box(100);
  for (int i = 0; i < 1000; ++i)
    box.push(1, "tick " + std::to_string(i));  // a 1 kHz channel, a client that stalls
  CHECK(box.dropped(1) == 900);
  CHECK(box.queued() == 100);
  box.push(2, "event");  // a rare one
  box.push_control("{\"op\":\"status\"}");
  view::Frame f;
  REQUIRE(box.pop(f, std::chrono::milliseconds(0)));
  CHECK(f.text);  // control first
  // The rare channel within the next two frames (round robin), not after the 100 ticks.
  std::vector<std::string> next;
  for (int i = 0; i < 2; ++i) {
    REQUIRE(box.pop(f, std::chrono::milliseconds(0)));
    next.push_back(*f.data);
  }
  CHECK(std::find(next.begin(), next.end(), "event") != next.end());
  CHECK(std::find(next.begin(), next.end(), "tick 900") != next.end());  // the oldest kept is the 900th
  CHECK(box.dropped(2) == 0);
  CHECK(box.dropped_total() == 900);
  box.set_limit(3, 2);
  for (int i = 0; i < 5; ++i) box.push(3, "p");
  CHECK(box.dropped(3) == 3);
  box.close();
  CHECK_FALSE(box.pop(f, std::chrono::milliseconds(0)));
}

TEST_CASE("view: the page's model follows the serving robot, decimates, and reports modules and processes") {
  view::LiveState::Options o;
  o.plot_every_ticks = 20;
  view::LiveState s({{"m1", 19.62}}, o);
  record::WorldReport wr;
  wr.set_module_id("m1");
  wr.set_tick(100);
  wr.set_normal_min(25.0);
  wr.add_braked(false);
  wr.add_braked(true);
  auto* left = wr.add_owners();
  left->set_arm("left");
  left->set_state(record::ARM_SERVED);
  left->set_robot("m1/left@50");
  left->set_strength(50);
  s.on_message("tandem/world_report/m1", wr, 1'000'000'000ULL);
  // The primary (100) and the serving standby (50) both command; only the server's points count, one in 20
  // ticks.
  for (int k = 0; k < 100; ++k) {
    for (const int strength : {100, 50}) {
      record::TorqueCommand c;
      c.set_tick(static_cast<uint64_t>(k));
      c.set_strength(strength);
      c.add_e_p(strength == 50 ? 0.003 : 9.0);
      c.add_e_p(strength == 50 ? 0.004 : 9.0);
      c.add_e_p(0.0);
      c.set_normal_force(strength == 50 ? 30.0 : -1.0);
      s.on_message("tandem/torque_commands/m1/left", c,
                   1'000'000'000ULL + static_cast<uint64_t>(k) * 1'000'000ULL);
    }
  }
  const json plot = json::parse(s.take_plot());
  REQUIRE(plot["points"].size() == 5);  // ticks 0, 20, 40, 60, 80
  CHECK(plot["points"][1]["tick"] == 20);
  CHECK(plot["points"][0]["ep"].get<double>() == Approx(0.005));  // |(3, 4)| mm
  CHECK(plot["points"][0]["hn"].get<double>() == Approx(30.0));
  CHECK(s.take_plot().empty());  // taken

  record::ProcessStatus ps;
  ps.set_process_id("m1/left@50");
  ps.set_role("robot");
  ps.set_module_id("m1");
  ps.set_state(2);
  ps.set_strength(50);
  s.on_message("tandem/process_status", ps, 2'000'000'000ULL);
  record::TaskState ts;
  ts.set_module_id("m1");
  ts.set_task_id(4);
  ts.set_state(1);
  ts.set_tasks_done(3);
  s.on_message("tandem/task_state", ts, 2'000'000'000ULL);
  const json st = json::parse(s.state(2'500'000'000ULL, {{"tandem/arm_sensors/m1/left", 12}}));
  REQUIRE(st["processes"].size() == 1);
  CHECK(st["processes"][0]["state"] == "active");
  CHECK(st["processes"][0]["heard_s_ago"].get<double>() == Approx(0.5));
  REQUIRE(st["modules"].size() == 1);
  const json& m = st["modules"][0];
  CHECK(m["grasp_margin"].get<double>() == Approx(25.0 - 19.62));
  CHECK(m["braked"] == json::array({false, true}));
  CHECK(m["owners"][0]["robot"] == "m1/left@50");
  CHECK(m["task"]["state"] == "running");
  CHECK(m["task"]["done"] == 3);
  CHECK(st["drops"]["tandem/arm_sensors/m1/left"] == 12);

  record::Event e;
  e.set_kind("failover");
  e.set_module_id("m1");
  e.set_subject("m1/left");
  for (int i = 0; i < 250; ++i) (void)s.on_event(e, 3'000'000'000ULL);
  CHECK(s.recent_events().size() == 200);  // bounded
  CHECK(json::parse(s.on_event(e, 3'000'000'000ULL))["kind"] == "failover");
}

TEST_CASE("view: a recording's timeline gives the page's state, plot window and events at a chosen time") {
  const std::string path = "/tmp/tandem-test-" + std::to_string(::getpid()) + "-timeline.mcap";
  const uint64_t t0 = 1'000'000'000'000ULL;  // log times [ns]
  {
    record::RecordingWriter w(path);
    w.metadata("deployment", {{"deployment", "d"}, {"module.m1.h_sg", "19.62"}});
    const uint16_t cmd = w.channel("tandem/torque_commands/m1/left", record::TorqueCommand::descriptor());
    const uint16_t rep = w.channel("tandem/world_report/m1", record::WorldReport::descriptor());
    const uint16_t ev = w.channel("tandem/events", record::Event::descriptor());
    for (int k = 0; k < 10000; ++k) {  // 10 s at 1 kHz
      const uint64_t t = t0 + static_cast<uint64_t>(k) * 1'000'000ULL;
      record::TorqueCommand c;
      c.set_tick(static_cast<uint64_t>(k));
      c.set_strength(100);
      c.add_e_p(0.001);
      c.add_e_p(0.0);
      c.set_normal_force(25.0);
      w.write(cmd, c, t);
      if (k % 10 == 0) {
        record::WorldReport r;
        r.set_module_id("m1");
        r.set_tick(static_cast<uint64_t>(k));
        r.set_normal_min(25.0);
        w.write(rep, r, t);
      }
      if (k == 2000 || k == 8000) {
        record::Event e;
        e.set_kind("failover");
        e.set_subject(k == 2000 ? "first" : "second");
        w.write(ev, e, t);
      }
    }
    w.close();
  }
  const view::Timeline tl = view::Timeline::from_recording(path);
  std::remove(path.c_str());
  CHECK(tl.start_s() == Approx(1000.0));
  CHECK(tl.end_s() == Approx(1009.999));
  CHECK(tl.points() == 500);  // one in 20 ticks
  CHECK(tl.events() == 2);
  const json at5 = json::parse(tl.at(1005.0, 2.0));
  CHECK(at5["events"].size() == 1);  // only the one before 5 s
  CHECK(at5["events"][0]["subject"] == "first");
  CHECK(at5["points"].size() == 100);  // the 2 s window before t: 100 points at 50 Hz
  CHECK(at5["points"].back()["t"].get<double>() <= 1005.0);
  REQUIRE(at5["state"]["modules"].size() == 1);
  CHECK(at5["state"]["modules"][0]["h_sg"].get<double>() ==
        Approx(19.62));  // from the metadata at the file's end
  CHECK(at5["state"]["modules"][0]["grasp_margin"].get<double>() == Approx(25.0 - 19.62));
  CHECK(json::parse(tl.at(1009.9))["events"].size() == 2);
  CHECK(json::parse(tl.at(999.0))["state"].is_null());  // before the recording
  CHECK_THROWS(view::Timeline::from_recording("/nonexistent/run.mcap"));
}

TEST_CASE("live commands: the page's requests as CLI command lines, bad ones refused by field", "[view]") {
  using tandem::view::cli_args;
  using tandem::view::parse_live_command;
  const auto k = parse_live_command(R"({"command": "kill", "target": "m1/left@50"})");
  CHECK(cli_args(k, "d.yaml") == std::vector<std::string>{"kill", "d.yaml", "m1/left@50"});
  const auto u = parse_live_command(R"({"command": "unplug", "kind": "module", "target": "m2"})");
  CHECK(cli_args(u, "d.yaml") == std::vector<std::string>{"unplug", "d.yaml", "module", "m2"});
  const auto p = parse_live_command(R"({"command": "plug", "kind": "robot", "target": "m1/left", "standby": true})");
  CHECK(cli_args(p, "/x/d.yaml") == std::vector<std::string>{"plug", "/x/d.yaml", "robot", "m1/left", "--standby"});
  CHECK(cli_args(parse_live_command(R"({"command": "down"})"), "d.yaml") == std::vector<std::string>{"down", "d.yaml"});
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"not json", "not JSON"},
      {"[1, 2]", "not a JSON object"},
      {R"({"command": "explode"})", "accepted: down, kill, plug, unplug"},
      {R"({"command": 3})", "'command' must be a string"},
      {R"({"command": "kill"})", "target ''"},
      {R"({"command": "kill", "target": "m1/left; rm -rf /"})", "not a process, robot or module name"},
      {R"({"command": "kill", "target": "--help"})", "not starting with -"},
      {R"({"command": "unplug", "target": "m1/left"})", "needs kind 'robot' or 'module'"},
      {R"({"command": "unplug", "kind": "robot", "target": "m1/left", "standby": true})", "standby is for plug robot only"},
      {R"({"command": "plug", "kind": "robot", "target": "m1/left", "standby": "yes"})", "'standby' must be true or false"},
      {R"({"command": "down", "target": "m1"})", "down takes no target"},
  };
  for (const auto& [body, says] : bad) {
    INFO(body);
    try {
      (void)parse_live_command(body);
      FAIL("accepted");
    } catch (const std::invalid_argument& e) {
      CHECK(std::string(e.what()).find(says) != std::string::npos);
    }
  }
}

TEST_CASE("live commands: this machine may command, another machine only with the viewer's token", "[view]") {
  using tandem::view::is_loopback;
  using tandem::view::refusal;
  CHECK(is_loopback("127.0.0.1"));
  CHECK(is_loopback("127.8.9.10"));
  CHECK(is_loopback("::1"));
  CHECK(is_loopback("::ffff:127.0.0.1"));
  CHECK_FALSE(is_loopback("10.0.0.5"));
  CHECK_FALSE(is_loopback("::ffff:10.0.0.5"));
  CHECK_FALSE(is_loopback("fe80::1"));
  const std::string token = tandem::view::make_token();
  CHECK(token.size() == 32);
  CHECK(token.find_first_not_of("0123456789abcdef") == std::string::npos);
  CHECK(tandem::view::make_token() != token);
  CHECK(refusal("127.0.0.1", "", "").empty());
  CHECK(refusal("127.0.0.1", "", token).empty());
  CHECK(refusal("10.0.0.5", token, token).empty());
  CHECK(refusal("10.0.0.5", "", token).find("not given") != std::string::npos);
  CHECK(refusal("10.0.0.5", token.substr(0, 31) + "x", token).find("wrong") != std::string::npos);
  CHECK(refusal("10.0.0.5", token + "0", token).find("wrong") != std::string::npos);
  CHECK(refusal("10.0.0.5", "anything", "").find("has none") != std::string::npos);
  CHECK(tandem::view::answer_json(true, "m1: \"killed\"\n") == R"({"ok":true,"text":"m1: \"killed\"\n"})");
  // Another web page open in a browser here: not JSON (a form or text/plain post needs no preflight), another Host
  // (DNS rebinding), another Origin.
  using tandem::view::browser_refusal;
  CHECK(browser_refusal("application/json", "http://127.0.0.1:8765", "127.0.0.1:8765", "127.0.0.1", 8765).empty());
  CHECK(browser_refusal("application/json; charset=utf-8", "", "localhost:8765", "127.0.0.1", 8765).empty());
  CHECK(browser_refusal("application/json", "", "10.1.2.3:9000", "10.1.2.3", 9000).empty());
  CHECK(browser_refusal("text/plain", "", "127.0.0.1:8765", "127.0.0.1", 8765).find("Content-Type") != std::string::npos);
  CHECK(browser_refusal("application/json", "", "evil.example:8765", "127.0.0.1", 8765).find("Host") != std::string::npos);
  CHECK(browser_refusal("application/json", "", "127.0.0.1:9999", "127.0.0.1", 8765).find("Host") != std::string::npos);
  CHECK(browser_refusal("application/json", "http://evil.example", "127.0.0.1:8765", "127.0.0.1", 8765).find("origin") !=
        std::string::npos);
}
