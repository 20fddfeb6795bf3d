// Multi-host deployments: where each process runs (the hosts: and placement keys), the errors for bad
// placements, and the launcher's host liveness (launcher::HostWatch). The agents and the network cut run in
// tests/multihost/multihost.sh.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <fstream>
#include <string>

#include "tandem/launcher/host_watch.hpp"
#include "tandem/runtime/deployment.hpp"
#include "tandem/runtime/security.hpp"

namespace {

const std::string kScenario = std::string(TANDEM_SOURCE_DIR) + "/config/scenarios/paper.yaml";

std::string write(const std::string& body) {
  std::string path = "/tmp/tandem-unit-multihost-" + std::to_string(::getpid()) + ".yaml";
  std::ofstream(path) << "name: mh\ndomain_id: 9\n" << body;
  return path;
}

const std::string kHosts = "hosts:\n  a: {address: 10.1.0.1}\n  b: {address: 10.1.0.2}\n  c: {address: 10.1.0.3}\n";

std::string refusal(const std::string& body) {
  const std::string path = write(body);
  std::string out = "accepted";
  try {
    (void)tandem::runtime::load_deployment(path);
  } catch (const std::exception& e) {
    out = e.what();
  }
  std::remove(path.c_str());
  return out;
}

}  // namespace

TEST_CASE("placement: every process of a module goes to its own host, or to the module's", "[multihost]") {
  const auto d = tandem::runtime::load_deployment(write(
      kHosts + "discovery: server\ndiscovery_address: 10.1.0.1\ncoordinator:\n  host: a\n  standby_host: c\n  tasks:\n"
               "    - {name: t, segments: [{to: [0.0, 0.8, 0.0], duration: 1.0}]}\n"
               "modules:\n  - name: m1\n    scenario: " + kScenario + "\n    case: SOSM\n    host: a\n"
               "    supervisor_standby_host: c\n    robot_hosts: {left: b}\n    standby_hosts: {right: c}\n"));
  REQUIRE(d.hosts.size() == 3);
  CHECK(d.hosts[1].name == "b");
  CHECK(d.hosts[1].address == "10.1.0.2");
  CHECK(d.discovery_address == "10.1.0.1");
  const auto& m = d.modules.at(0);
  using tandem::runtime::host_of;
  CHECK(host_of(m, "world", "", false) == "a");
  CHECK(host_of(m, "supervisor", "supervisor", false) == "a");
  CHECK(host_of(m, "supervisor", "supervisor", true) == "c");
  CHECK(host_of(m, "robot", "left", false) == "b");
  CHECK(host_of(m, "robot", "left", true) == "b");  // a standby without its own host: on its primary's
  CHECK(host_of(m, "robot", "right", false) == "a");
  CHECK(host_of(m, "robot", "right", true) == "c");
  CHECK(tandem::runtime::coordinator_host_of(d, false) == "a");
  CHECK(tandem::runtime::coordinator_host_of(d, true) == "c");
  // Without hosts: nothing is placed (the launcher starts everything itself).
  const auto one = tandem::runtime::load_deployment(write("modules:\n  - {name: m1, scenario: " + kScenario + ", case: SOSM}\n"));
  CHECK(one.hosts.empty());
  CHECK(host_of(one.modules.at(0), "robot", "left", false).empty());
  std::remove(one.source.c_str());
}

TEST_CASE("bad placements are refused by name, with what is accepted", "[multihost]") {
  const std::string mod = "modules:\n  - {name: m1, scenario: " + kScenario + ", case: SOSM";
  CHECK_THAT(refusal(kHosts + mod + ", host: z}\n"), Catch::Contains("unknown host 'z'; hosts: a, b, c"));
  CHECK_THAT(refusal(kHosts + mod + "}\n"), Catch::Contains("every module needs a host"));
  CHECK_THAT(refusal(mod + ", host: a}\n"), Catch::Contains("needs a top-level 'hosts:' list"));
  CHECK_THAT(refusal(kHosts + mod + ", host: a, robot_hosts: {middle: b}}\n"),
             Catch::Contains("no robot 'middle' in"));
  CHECK_THAT(refusal(kHosts + mod + ", host: a, standby_hosts: {left: q}}\n"), Catch::Contains("unknown host 'q'"));
  CHECK_THAT(refusal("hosts:\n  a: {address: 10.1.0.300}\n" + mod + ", host: a}\n"),
             Catch::Contains("expected an IPv4 address, got '10.1.0.300'"));
  CHECK_THAT(refusal("hosts:\n  a: {}\n" + mod + ", host: a}\n"), Catch::Contains("missing required field"));
  CHECK_THAT(refusal("hosts:\n  a: {address: 10.1.0.1}\n  b: {address: 10.1.0.1}\n" + mod + ", host: a}\n"),
             Catch::Contains("hosts 'a' and 'b' have the same address 10.1.0.1"));
  CHECK_THAT(refusal("hosts:\n  a: {address: 10.1.0.1, port: 3}\n" + mod + ", host: a}\n"),
             Catch::Contains("unknown key; accepted keys here: address"));
  CHECK_THAT(refusal("discovery_address: somewhere\n" + mod + "}\n"), Catch::Contains("expected an IPv4 address"));
  CHECK_THAT(refusal("discovery: server\n" + kHosts + mod + ", host: a}\n"),
             Catch::Contains("'discovery_address': the Discovery Server at 127.0.0.1 (loopback) cannot be reached"));
  CHECK_THAT(refusal(kHosts + mod + ", host: a}\ncoordinator:\n  tasks:\n"
                                    "    - {name: t, segments: [{to: [0.0, 0.8, 0.0], duration: 1.0}]}\n"),
             Catch::Contains("the coordinator needs a host"));
}

TEST_CASE("host watch: a host is lost after the timeout of silence, once, and back when heard", "[multihost]") {
  tandem::launcher::HostWatch w({"a", "b"}, 1.0);
  CHECK(w.waiting() == std::vector<std::string>{"a", "b"});
  CHECK_FALSE(w.heard("a", 0.0));
  CHECK(w.waiting() == std::vector<std::string>{"b"});
  CHECK(w.up("a"));
  CHECK_FALSE(w.up("b"));
  CHECK(w.newly_lost(5.0) == std::vector<std::string>{"a"});  // b was never heard: waiting, not lost
  CHECK(w.lost("a"));
  CHECK(w.newly_lost(6.0).empty());  // reported once
  CHECK(w.heard("a", 6.5));          // back
  CHECK(w.up("a"));
  CHECK_FALSE(w.heard("a", 6.6));
  w.heard("b", 6.6);
  CHECK(w.newly_lost(7.5).empty());                           // 0.9 s and 0.9 s of silence
  CHECK(w.newly_lost(7.7) == std::vector<std::string>{"a", "b"});  // 1.1 s
  // A time in which nobody read the heartbeats does not count as silence.
  w.heard("a", 8.0);
  w.heard("b", 8.0);
  w.restart_clock(20.0);
  CHECK(w.newly_lost(20.9).empty());
  CHECK(w.newly_lost(21.1) == std::vector<std::string>{"a", "b"});
  CHECK_FALSE(w.heard("zz", 8.0));                            // unknown hosts are ignored
  CHECK_FALSE(w.known("zz"));
}

TEST_CASE("security on several hosts: an identity per agent that may only write its own state and status", "[multihost]") {
  const std::string path = write(kHosts + "security:\n  keys: k\nmodules:\n  - {name: m1, scenario: " + kScenario +
                                 ", case: SOSM, host: a, robot_hosts: {left: b, right: c}}\n");
  const auto d = tandem::runtime::load_deployment(path);
  std::remove(path.c_str());
  const auto ids = tandem::runtime::identities(d);
  auto find = [&](const std::string& name) -> const tandem::runtime::Identity& {
    for (const auto& id : ids) {
      if (id.name == name) return id;
    }
    FAIL("no identity " << name);
    throw std::logic_error("unreachable");
  };
  for (const char* h : {"a", "b", "c"}) {
    const auto& agent = find(tandem::runtime::identity_name("agent", h));
    CHECK(agent.publish == std::vector<std::string>{"tandem/agent_state", "tandem/process_status"});
    CHECK(agent.subscribe == std::vector<std::string>{"tandem/agent_request", "tandem/agent_state"});
  }
  const auto& launcher = find("launcher");
  CHECK(std::count(launcher.publish.begin(), launcher.publish.end(), "tandem/agent_request") == 1);
  CHECK(std::count(launcher.subscribe.begin(), launcher.subscribe.end(), "tandem/agent_state") == 1);
  // Nobody else may ask an agent for anything.
  for (const auto& id : ids) {
    if (id.name == "launcher") continue;
    INFO(id.name);
    CHECK(std::count(id.publish.begin(), id.publish.end(), "tandem/agent_request") == 0);
  }
}

TEST_CASE("deployment: a task name given twice is refused, naming both, 12 000 tasks load in well under a second", "[multihost]") {
  const std::string mod = "modules:\n  - {name: m1, scenario: " + kScenario + ", case: SOSM}\n";
  const std::string seg = ", segments: [{to: [0.2, 0.8, 0.0], duration: 1.0}]}\n";
  const std::string dup = refusal(mod + "coordinator:\n  tasks:\n    - {name: a" + seg + "    - {name: b" + seg +
                                  "    - {name: a" + seg);
  INFO(dup);
  CHECK(dup.find("task names must be unique ('a' twice)") != std::string::npos);
  CHECK(dup.find("tasks[2]") != std::string::npos);
  // A soak's hour derives about 12 000 tasks; every coordinator start loads them. The name check is linear now
  // (it was pairwise: 72 million comparisons). Not a timing assertion: the load must simply finish and keep order.
  std::string many = mod + "coordinator:\n  tasks:\n";
  for (int i = 0; i < 12000; ++i) many += "    - {name: t" + std::to_string(i) + seg;
  const std::string path = write(many);
  const auto d = tandem::runtime::load_deployment(path);
  std::remove(path.c_str());
  REQUIRE(d.tasks.size() == 12000);
  CHECK(d.tasks.front().name == "t0");
  CHECK(d.tasks.back().name == "t11999");
}
