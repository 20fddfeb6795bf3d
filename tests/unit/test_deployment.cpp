// A deployment written from its struct (runtime::deployment_yaml) reads back as the same deployment, from any
// directory; the soak's derived deployment is such a file.
#include <unistd.h>

#include <catch2/catch.hpp>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "tandem/dds/bus.hpp"
#include "tandem/runtime/deployment.hpp"
#include "tandem/soak/run.hpp"

using tandem::runtime::Deployment;

namespace {

/// Every field of two deployments, one CHECK each (a field the writer forgot shows here by name).
void check_same(const Deployment& a, const Deployment& b) {
  CHECK(a.name == b.name);
  CHECK(a.domain_id == b.domain_id);
  CHECK(a.transport == b.transport);
  CHECK(a.timing == b.timing);
  CHECK(a.timeout == b.timeout);
  CHECK(a.start_timeout == b.start_timeout);
  CHECK(a.realtime_priority == b.realtime_priority);
  CHECK(a.cpu_affinity == b.cpu_affinity);
  CHECK(a.spin_limit == b.spin_limit);
  CHECK(a.overload_brake == b.overload_brake);
  CHECK(a.shed_modules == b.shed_modules);
  CHECK(a.test_no_brakes == b.test_no_brakes);
  CHECK(a.discovery == b.discovery);
  CHECK(a.discovery_port == b.discovery_port);
  CHECK(a.discovery_address == b.discovery_address);
  CHECK(a.discovery_start == b.discovery_start);
  CHECK(a.discovery_servers == b.discovery_servers);
  CHECK(a.module_start == b.module_start);
  CHECK(a.host_timeout == b.host_timeout);
  REQUIRE(a.hosts.size() == b.hosts.size());
  for (size_t i = 0; i < a.hosts.size(); ++i) {
    CHECK(a.hosts[i].name == b.hosts[i].name);
    CHECK(a.hosts[i].address == b.hosts[i].address);
  }
  CHECK(a.coordinator_host == b.coordinator_host);
  CHECK(a.coordinator_standby_host == b.coordinator_standby_host);
  REQUIRE(a.modules.size() == b.modules.size());
  for (size_t i = 0; i < a.modules.size(); ++i) {
    const auto& x = a.modules[i];
    const auto& y = b.modules[i];
    CHECK(x.name == y.name);
    CHECK(std::filesystem::weakly_canonical(x.scenario) == std::filesystem::weakly_canonical(y.scenario));
    CHECK(x.case_name == y.case_name);
    CHECK(x.standby == y.standby);
    CHECK(x.supervisor_standby == y.supervisor_standby);
    CHECK(x.restart == y.restart);
    CHECK(x.restart_limit == y.restart_limit);
    CHECK(x.restart_window == y.restart_window);
    CHECK(x.restart_backoff == y.restart_backoff);
    CHECK(x.restart_as == y.restart_as);
    CHECK(x.autostart == y.autostart);
    CHECK(x.host == y.host);
    CHECK(x.supervisor_host == y.supervisor_host);
    CHECK(x.supervisor_standby_host == y.supervisor_standby_host);
    CHECK(x.robot_hosts == y.robot_hosts);
    CHECK(x.standby_hosts == y.standby_hosts);
  }
  CHECK(a.coordinator == b.coordinator);
  REQUIRE(a.tasks.size() == b.tasks.size());
  for (size_t i = 0; i < a.tasks.size(); ++i) {
    CHECK(a.tasks[i].name == b.tasks[i].name);
    CHECK(a.tasks[i].waypoints == b.tasks[i].waypoints);
  }
  CHECK(a.balance == b.balance);
  CHECK(a.coordinator_standby == b.coordinator_standby);
  CHECK(a.coordinator_restart == b.coordinator_restart);
  CHECK(a.coordinator_restart_limit == b.coordinator_restart_limit);
  CHECK(a.coordinator_restart_window == b.coordinator_restart_window);
  CHECK(a.record == b.record);
  CHECK(a.record_topics == b.record_topics);
  CHECK((a.security_keys.empty() ? std::string() : std::filesystem::weakly_canonical(a.security_keys).string()) ==
        (b.security_keys.empty() ? std::string() : std::filesystem::weakly_canonical(b.security_keys).string()));
}

/// A directory outside the repository, removed at the end.
struct TempDir {
  std::string path = "/tmp/tandem-unit-deployment-" + std::to_string(::getpid());
  TempDir() { std::filesystem::create_directories(path); }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

}  // namespace

TEST_CASE("deployment: every shipped deployment written from its struct reads back the same, from another directory") {
  const TempDir tmp;
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(std::string(TANDEM_SOURCE_DIR) + "/deploy")) {
    if (entry.path().extension() != ".yaml") continue;
    INFO(entry.path().string());
    const Deployment d = tandem::runtime::load_deployment(entry.path().string());
    const std::string yaml = tandem::runtime::deployment_yaml(d);
    const std::string copy = tmp.path + "/" + entry.path().filename().string();
    std::ofstream(copy) << yaml;
    const Deployment back = tandem::runtime::load_deployment(copy);
    check_same(d, back);
    CHECK(tandem::runtime::deployment_yaml(back) == yaml);  // written again: the same text
    ++files;
  }
  CHECK(files >= 8);
}

TEST_CASE("deployment: a multi-host deployment with placements, a coordinator and unusual values round-trips") {
  const TempDir tmp;
  const std::string src = tmp.path + "/src.yaml";
  std::ofstream(src) << "name: rich\ndomain_id: 17\ntransport: udp\ntiming: realtime\ntimeout: 7.5\nstart_timeout: 33\n"
                        "realtime_priority: 40\ncpu_affinity: module\nspin_limit: 0.75\noverload_brake: false\nshed_modules: false\ndiscovery: server\n"
                        "discovery_port: 12000\ndiscovery_address: 10.1.0.1\ndiscovery_start: external\nhost_timeout: 2.5\n"
                        "hosts:\n  a: {address: 10.1.0.1}\n  b: {address: 10.1.0.2}\n"
                        "record: run.mcap\nrecord_topics: ticks,events\n"
                        "modules:\n  - {name: m1, scenario: "
                     << TANDEM_SOURCE_DIR << "/config/scenarios/paper.yaml, case: PD, standby: 2, supervisor_standby: 1,"
                        " restart: always, restart_limit: 9, restart_window: 12.5, restart_backoff: 0.3, restart_as: primary,"
                        " autostart: false, host: a, supervisor_host: b, supervisor_standby_host: a,"
                        " robot_hosts: {left: b}, standby_hosts: {right: b}}\n"
                        "coordinator:\n  balance: round_robin\n  standby: 2\n  restart: on-failure\n  restart_limit: 5\n"
                        "  restart_window: 45\n  host: b\n  standby_host: a\n"
                        "  tasks:\n    - {name: t1, segments: [{to: [0.15, 0.8, 0.0], duration: 1.25}, {to: [-0.1, 0.85, 0.0], duration: 2}]}\n";
  const Deployment d = tandem::runtime::load_deployment(src);
  REQUIRE(d.modules.size() == 1);
  REQUIRE(d.modules[0].robot_hosts.size() == 1);
  CHECK(d.spin_limit == 0.75);
  const std::string copy = tmp.path + "/copy.yaml";
  std::ofstream(copy) << tandem::runtime::deployment_yaml(d);
  check_same(d, tandem::runtime::load_deployment(copy));
}

TEST_CASE("deployment: the soak's derived deployment loads from a report directory outside the repository") {
  // `tandem soak deploy/soak-four.yaml --report DIR` with DIR anywhere: the derived file names its scenarios by
  // absolute paths, keeps everything else of the user's file, and adds the soak's tasks.
  const TempDir tmp;
  const std::string file = std::string(TANDEM_SOURCE_DIR) + "/deploy/soak-small.yaml";
  const Deployment d = tandem::runtime::load_deployment(file);
  size_t generated = 0;
  const std::string derived = tmp.path + "/report/deploy.yaml";
  std::filesystem::create_directories(tmp.path + "/report");
  std::ofstream(derived) << tandem::soak::derived_deployment(file, d, "lockstep", "udp", 120.0, generated);
  const Deployment s = tandem::runtime::load_deployment(derived);
  CHECK(s.timing == "lockstep");
  CHECK(s.transport == "udp");
  CHECK(s.coordinator);
  CHECK(generated > 100);
  CHECK(s.tasks.size() == d.tasks.size() + generated);
  CHECK(s.tasks.back().name == "soak-" + std::to_string(generated));
  REQUIRE(s.modules.size() == d.modules.size());
  for (size_t i = 0; i < s.modules.size(); ++i) {
    CHECK(s.modules[i].scenario[0] == '/');
    CHECK(s.modules[i].standby == d.modules[i].standby);
    CHECK(s.modules[i].restart == d.modules[i].restart);
  }
  CHECK(s.domain_id == d.domain_id);
  CHECK(s.coordinator_standby == d.coordinator_standby);
}

TEST_CASE("a Discovery Server client announces itself every 5 s and its lease ends after 12 s, a simple "
          "participant announces every 1 s (soak finding 74)", "[deployment]") {
  namespace dds = tandem::dds;
  // ROS_DISCOVERY_SERVER as it was, whatever happens below.
  struct EnvGuard {
    std::string saved;
    bool had = false;
    EnvGuard() {
      if (const char* v = std::getenv("ROS_DISCOVERY_SERVER")) {
        saved = v;
        had = true;
      }
    }
    ~EnvGuard() {
      if (had) {
        ::setenv("ROS_DISCOVERY_SERVER", saved.c_str(), 1);
      } else {
        ::unsetenv("ROS_DISCOVERY_SERVER");
      }
    }
  } guard;
  // Domain 231: no other test uses it (the distributed tests take 100-219); nothing listens on the server's port
  // (a client only pings it).
  ::setenv("ROS_DISCOVERY_SERVER", "127.0.0.1:19999", 1);
  {
    dds::Participant client(231, "test/ds-client", dds::Transport::Udp);
    const auto& dc = client.get()->get_qos().wire_protocol().builtin.discovery_config;
    // (Fast DDS turns the participant into a client of that server below the DDS layer; get_qos still says SIMPLE.)
    CHECK(dc.leaseDuration_announcementperiod.seconds == 5);
    CHECK(dc.leaseDuration.seconds == 12);
    // The lease holds more than two announcement periods: one lost announcement does not end a live client.
    CHECK(dc.leaseDuration.seconds > 2 * dc.leaseDuration_announcementperiod.seconds);
  }
  ::unsetenv("ROS_DISCOVERY_SERVER");
  {
    dds::Participant simple(231, "test/simple", dds::Transport::Udp);
    const auto& dc = simple.get()->get_qos().wire_protocol().builtin.discovery_config;
    CHECK(dc.leaseDuration_announcementperiod.seconds == 1);
  }
}

TEST_CASE("deployment: one Discovery Server per module, a module's processes name only their own, in its place",
          "[deployment]") {
  // Soak finding 74: one server relayed every module's churn to every process. Server i serves module i; a client
  // names server k by its place in ROS_DISCOVERY_SERVER (k ';' before it), so the place is the server's id.
  const TempDir tmp;
  const std::string mods = std::string("modules:\n") + "  - {name: a, scenario: " + TANDEM_SOURCE_DIR +
                           "/config/scenarios/paper.yaml, case: SOSM}\n  - {name: b, scenario: " + TANDEM_SOURCE_DIR +
                           "/config/scenarios/paper.yaml, case: SOSM}\n  - {name: c, scenario: " + TANDEM_SOURCE_DIR +
                           "/config/scenarios/paper.yaml, case: SOSM}\n";
  auto load = [&](const std::string& head) {
    const std::string path = tmp.path + "/d.yaml";
    std::ofstream(path) << "name: ds\ndomain_id: 40\n" << head << mods;
    return tandem::runtime::load_deployment(path);
  };
  namespace rt = tandem::runtime;
  const Deployment per = load("discovery: server\n");
  CHECK(per.discovery_servers == "module");
  const auto servers = rt::discovery_servers(per);
  REQUIRE(servers.size() == 3);
  for (int i = 0; i < 3; ++i) {
    CHECK(servers[static_cast<size_t>(i)].id == i);
    CHECK(servers[static_cast<size_t>(i)].port == 11851 + i * rt::kDiscoveryPortStride);  // 11811 + domain 40
    CHECK(servers[static_cast<size_t>(i)].module == std::string(1, static_cast<char>('a' + i)));
  }
  CHECK(rt::discovery_env(per) == "127.0.0.1:11851;127.0.0.1:12107;127.0.0.1:12363");
  CHECK(rt::discovery_env(per, "a") == "127.0.0.1:11851");
  CHECK(rt::discovery_env(per, "b") == ";127.0.0.1:12107");
  CHECK(rt::discovery_env(per, "c") == ";;127.0.0.1:12363");
  CHECK(rt::discovery_text(per) == "127.0.0.1:11851 and 2 more (one server per module, ports 256 apart)");
  // A slot inside the deployment's own RTPS ports (domain 18: 7400 + 250 * 18 = 11900, 250 ports) is skipped: the
  // second server goes to the third slot, and the ids stay 0, 1, 2.
  {
    const std::string path = tmp.path + "/d18.yaml";
    std::ofstream(path) << "name: ds\ndomain_id: 18\ndiscovery: server\n" << mods;
    const auto s18 = rt::discovery_servers(tandem::runtime::load_deployment(path));
    REQUIRE(s18.size() == 3);
    CHECK(s18[0].port == 11829);
    CHECK(s18[1].port == 11829 + 2 * rt::kDiscoveryPortStride);  // 12085 would be inside [11900, 12150)
    CHECK(s18[1].id == 1);
    CHECK(s18[2].port == 11829 + 3 * rt::kDiscoveryPortStride);
  }
  // One server for all: every process names server 0.
  const Deployment one = load("discovery: server\ndiscovery_servers: one\n");
  REQUIRE(rt::discovery_servers(one).size() == 1);
  CHECK(rt::discovery_env(one, "b") == "127.0.0.1:11851");
  CHECK(rt::discovery_env(one) == "127.0.0.1:11851");
  CHECK(rt::discovery_text(one) == "127.0.0.1:11851");
  // An external server is one server: the default follows, and asking for one per module is refused by name.
  const Deployment ext = load("discovery: server\ndiscovery_start: external\n");
  CHECK(ext.discovery_servers == "one");
  CHECK(rt::discovery_servers(ext).size() == 1);
  CHECK_THROWS_WITH(load("discovery: server\ndiscovery_start: external\ndiscovery_servers: module\n"),
                    Catch::Contains("discovery_servers") && Catch::Contains("needs discovery_start: launcher"));
  CHECK_THROWS_WITH(load("discovery: server\ndiscovery_servers: two\n"), Catch::Contains("discovery_servers"));
  // Ports past 65535 are refused, naming the way out.
  CHECK_THROWS_WITH(load("discovery: server\ndiscovery_port: 65300\n"),
                    Catch::Contains("discovery_servers: one, or a lower discovery_port"));
  // Simple discovery: no server, no variable.
  const Deployment simple = load("");
  CHECK(rt::discovery_servers(simple).empty());
  CHECK(rt::discovery_env(simple, "a").empty());
  CHECK(rt::discovery_text(simple) == "simple");
  // Modules start one by one by default with simple discovery and more than two modules (three here), together with
  // a server; either can be asked for, and nothing else.
  CHECK(simple.module_start == "one_by_one");
  CHECK(per.module_start == "together");
  CHECK(load("module_start: together\n").module_start == "together");
  CHECK(load("discovery: server\nmodule_start: one_by_one\n").module_start == "one_by_one");
  CHECK_THROWS_WITH(load("module_start: staggered\n"), Catch::Contains("module_start") && Catch::Contains("one_by_one"));
}
