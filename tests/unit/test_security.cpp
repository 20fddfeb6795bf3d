// The security documents derived from a deployment (runtime::identities, permissions_xml, governance_xml):
// least privilege per identity, checked on deploy/secure-one-module.yaml.
#include <sys/stat.h>
#include <unistd.h>

#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "tandem/dds/qos.hpp"
#include "tandem/runtime/security.hpp"

using namespace tandem::runtime;

namespace {
const Identity& find(const std::vector<Identity>& ids, const std::string& name) {
  const auto it = std::find_if(ids.begin(), ids.end(), [&](const Identity& i) { return i.name == name; });
  REQUIRE(it != ids.end());
  return *it;
}
bool has(const std::vector<std::string>& v, const std::string& s) { return std::find(v.begin(), v.end(), s) != v.end(); }
}  // namespace

TEST_CASE("each identity may publish and read only what its role needs", "[security]") {
  const Deployment d = load_deployment(std::string(TANDEM_SOURCE_DIR) + "/deploy/secure-one-module.yaml");
  REQUIRE_FALSE(d.security_keys.empty());
  const auto ids = identities(d);
  CHECK(ids.size() == 8);  // 2 robots, world, supervisor, coordinator, launcher, cli, recorder
  const Identity& left = find(ids, "robot.m1.left");
  CHECK(has(left.publish, "tandem/torque_commands/m1/left"));
  CHECK_FALSE(has(left.publish, "tandem/torque_commands/m1/right"));
  CHECK_FALSE(has(left.publish, "tandem/control"));
  CHECK(has(left.subscribe, "tandem/arm_sensors/m1/left"));
  CHECK_FALSE(has(left.subscribe, "tandem/arm_sensors/m1/right"));
  // Only the launcher and the CLI write control requests.
  for (const auto& id : ids) {
    INFO(id.name);
    CHECK(has(id.publish, "tandem/control") == (id.name == "launcher" || id.name == "cli"));
    for (const auto& t : id.publish) CHECK(t.find('*') == std::string::npos);  // no wildcard writes
  }
  const Identity& world = find(ids, "world.m1");
  CHECK(has(world.publish, "tandem/arm_sensors/m1/left"));
  CHECK(has(world.subscribe, "tandem/torque_commands/m1/right"));
  CHECK(find(ids, "recorder").publish == std::vector<std::string>{"tandem/process_status"});
  CHECK(identity_name("robot", "m2", "right") == "robot.m2.right");
  CHECK(identity_name("supervisor", "m2") == "supervisor.m2");
}

TEST_CASE("the permissions document has one default-deny grant per identity, on the deployment's domain", "[security]") {
  const Deployment d = load_deployment(std::string(TANDEM_SOURCE_DIR) + "/deploy/secure-one-module.yaml");
  const auto ids = identities(d);
  const std::string x = permissions_xml(ids, d.domain_id, "2026-01-01T00:00:00", "2027-01-01T00:00:00");
  size_t grants = 0;
  for (size_t at = x.find("<grant "); at != std::string::npos; at = x.find("<grant ", at + 1)) ++grants;
  CHECK(grants == ids.size());
  CHECK(x.find("<subject_name>CN=robot.m1.left</subject_name>") != std::string::npos);
  CHECK(x.find("<domains><id>48</id></domains>") != std::string::npos);
  CHECK(x.find("<default>DENY</default>") != std::string::npos);
  const std::string g = governance_xml(d);
  CHECK(g.find("<allow_unauthenticated_participants>false</allow_unauthenticated_participants>") != std::string::npos);
  CHECK(g.find("<data_protection_kind>ENCRYPT</data_protection_kind>") != std::string::npos);
  CHECK(g.find("<enable_write_access_control>true</enable_write_access_control>") != std::string::npos);
  CHECK(g.find("<enable_read_access_control>false</enable_read_access_control>") == std::string::npos);
  // By topic class: on one host over shared memory the per-tick topics (first rules) carry no per-sample crypto
  // and keep data-sharing; access control stays on for them; everything else is encrypted (the last rule).
  Deployment local = d;
  local.transport = "shm";
  local.hosts.clear();
  REQUIRE(per_tick_local(local));
  const std::string gl = governance_xml(local);
  const auto sensors = gl.find("<topic_expression>tandem/arm_sensors/m1/left</topic_expression>");
  const auto torques = gl.find("<topic_expression>tandem/torque_commands/m1/right</topic_expression>");
  const auto rest = gl.find("<topic_expression>*</topic_expression>");
  REQUIRE(sensors != std::string::npos);
  REQUIRE(torques != std::string::npos);
  REQUIRE(rest != std::string::npos);
  CHECK(sensors < rest);
  CHECK(torques < rest);
  CHECK(gl.find("<data_protection_kind>NONE</data_protection_kind>", sensors) < rest);
  CHECK(gl.find("<data_protection_kind>ENCRYPT</data_protection_kind>", rest) != std::string::npos);
  size_t access = 0;
  for (size_t at = gl.find("<enable_write_access_control>true"); at != std::string::npos; at = gl.find("<enable_write_access_control>true", at + 1)) ++access;
  CHECK(access == 5);  // the four per-tick topics of m1's two arms, and the rest
  // Over UDP (or across hosts) the per-tick samples cross a wire a capture can read: encrypted like the rest.
  Deployment wire = local;
  wire.transport = "udp";
  CHECK_FALSE(per_tick_local(wire));
  CHECK(governance_xml(wire).find("tandem/arm_sensors/") == std::string::npos);
}

TEST_CASE("security in a deployment: a missing keys directory or a discovery server is refused by name", "[security]") {
  // use_security names the missing file and the command that makes it.
  Deployment d = load_deployment(std::string(TANDEM_SOURCE_DIR) + "/deploy/secure-one-module.yaml");
  d.security_keys = "/nonexistent-tandem-keys";
  const std::string err = use_security(d, "cli");
  CHECK(err.find("/nonexistent-tandem-keys/ca.pem is missing") != std::string::npos);
  CHECK(err.find("tandem keys") != std::string::npos);
  CHECK(check_keys(d).find("is missing") != std::string::npos);
}

TEST_CASE("security with a discovery server, or without a keys directory, is refused when the file is read", "[security]") {
  const std::string path = "/tmp/tandem-security-test-" + std::to_string(::getpid()) + ".yaml";
  const std::string scenario = std::string(TANDEM_SOURCE_DIR) + "/config/scenarios/paper.yaml";
  auto load = [&](const std::string& extra) {
    std::ofstream(path) << "name: s\ndomain_id: 3\n" << extra << "modules:\n  - {name: m1, scenario: " << scenario
                        << ", case: SOSM}\n";
    try {
      load_deployment(path);
    } catch (const std::exception& e) {
      std::remove(path.c_str());
      return std::string(e.what());
    }
    std::remove(path.c_str());
    return std::string();
  };
  CHECK(load("discovery: server\nsecurity: {keys: k}\n").find("not supported") != std::string::npos);
  CHECK(load("security: {}\n").find("security.keys") != std::string::npos);
  CHECK(load("security: {keys: k, cipher: rot13}\n").find("cipher") != std::string::npos);
  CHECK(load("security: {keys: k}\n").empty());
}

TEST_CASE("secured data-sharing segments go in a directory only this user can enter", "[security]") {
  const std::string dir = tandem::dds::private_shm_dir();
  REQUIRE_FALSE(dir.empty());
  struct stat st {};
  REQUIRE(::stat(dir.c_str(), &st) == 0);
  CHECK(S_ISDIR(st.st_mode));
  CHECK((st.st_mode & 0777) == 0700);
  CHECK(st.st_uid == ::getuid());
  CHECK(dir == "/dev/shm/tandem-" + std::to_string(::getuid()));
}

TEST_CASE("torque commands of a plain deployment go by the shared-memory transport, sensor samples by data-sharing",
          "[security][dds]") {
  // A data-sharing reader dies with a writer killed mid-write (Fast DDS 2.9.1; bench/peer_kill.sh), and robots,
  // the torque writers, are killed and restarted by design: their world must not go with them.
  using tandem::dds::TopicKind;
  namespace fdds = eprosima::fastdds::dds;
  const char* had = std::getenv("TANDEM_SECURITY_DIR");
  const std::string saved = had != nullptr ? had : "";
  ::unsetenv("TANDEM_SECURITY_DIR");
  CHECK_FALSE(tandem::dds::shares_data(TopicKind::TorquesRealtime, true));
  CHECK_FALSE(tandem::dds::shares_data(TopicKind::Torques, true));
  CHECK(tandem::dds::shares_data(TopicKind::SensorsRealtime, true));
  CHECK_FALSE(tandem::dds::shares_data(TopicKind::Sensors, true));  // lockstep's: a killed reader aborted the world
  CHECK_FALSE(tandem::dds::shares_data(TopicKind::SensorsRealtime, false));  // UDP deployments: none
  CHECK_FALSE(tandem::dds::shares_data(TopicKind::Status, true));
  CHECK(tandem::dds::reader_qos(TopicKind::TorquesRealtime).data_sharing().kind() == fdds::OFF);
  CHECK(tandem::dds::writer_qos(TopicKind::TorquesRealtime).data_sharing().kind() == fdds::OFF);
  CHECK(tandem::dds::writer_qos(TopicKind::SensorsRealtime).data_sharing().kind() == fdds::AUTO);
  // Secured: the transport's segments are readable by other users and per-tick samples are not encrypted, so
  // torques stay in the private data-sharing directory.
  ::setenv("TANDEM_SECURITY_DIR", "/nonexistent-keys", 1);
  CHECK(tandem::dds::shares_data(TopicKind::TorquesRealtime, true));
  CHECK(tandem::dds::shares_data(TopicKind::Sensors, true));
  if (saved.empty()) {
    ::unsetenv("TANDEM_SECURITY_DIR");
  } else {
    ::setenv("TANDEM_SECURITY_DIR", saved.c_str(), 1);
  }
}

TEST_CASE("certificates are checked with OpenSSL's X509 API: missing, not a certificate, expired", "[security]") {
  const std::string dir = "/tmp/tandem-cert-test-" + std::to_string(::getpid());
  ::mkdir(dir.c_str(), 0700);
  CHECK(tandem::runtime::certificate_problem(dir + "/none.pem") == "cannot be read");
  std::ofstream(dir + "/junk.pem") << "not a certificate\n";
  CHECK(tandem::runtime::certificate_problem(dir + "/junk.pem") == "is not a PEM certificate");
  // A quote in a path is just a path (the shell command this replaces broke on it).
  const std::string quoted = dir + "/it's.pem";
  std::ofstream(quoted) << "x\n";
  CHECK(tandem::runtime::certificate_problem(quoted) == "is not a PEM certificate");
  const std::string key = dir + "/k.pem", good = dir + "/good.pem", old = dir + "/old.pem";
  const std::string mk = "openssl req -x509 -newkey rsa:2048 -nodes -keyout " + key + " -subj /CN=t -out ";
  // openssl (a test dependency, scripts/install-deps.sh) makes a valid and an expired certificate.
  REQUIRE(std::system((mk + good + " -days 1 >/dev/null 2>&1").c_str()) == 0);
  CHECK(tandem::runtime::certificate_problem(good).empty());
  // Expired: a certificate whose validity ended yesterday (openssl x509 -days -1, self-signed with the same key).
  const std::string csr = dir + "/r.csr";
  REQUIRE(std::system(("openssl req -new -key " + key + " -subj /CN=t -out " + csr + " >/dev/null 2>&1 && openssl x509 -req -in " +
                       csr + " -signkey " + key + " -days -1 -out " + old + " >/dev/null 2>&1").c_str()) == 0);
  CHECK(tandem::runtime::certificate_problem(old) == "has expired");
  for (const char* f : {"/junk.pem", "/it's.pem", "/k.pem", "/good.pem", "/old.pem", "/r.csr"}) std::remove((dir + f).c_str());
  ::rmdir(dir.c_str());
}

TEST_CASE("keys made for another domain are refused before any participant is made, naming both domains", "[security]") {
  // The permissions grant one domain: a deployment whose domain_id changed after `tandem keys` would have every
  // topic refused at run time, with nothing logged. check_keys and use_security say so instead.
  Deployment d = load_deployment(std::string(TANDEM_SOURCE_DIR) + "/deploy/secure-one-module.yaml");
  const std::string dir = "/tmp/tandem-domain-test-" + std::to_string(::getpid());
  REQUIRE(::mkdir(dir.c_str(), 0700) == 0);
  d.security_keys = dir;
  const auto ids = identities(d);
  std::ofstream(dir + "/permissions.p7s") << permissions_xml(ids, d.domain_id + 1, "2026-01-01T00:00:00",
                                                             "2036-01-01T00:00:00");
  const std::string wrong = check_keys(d);
  CHECK(wrong.find("grants domain " + std::to_string(d.domain_id + 1)) != std::string::npos);
  CHECK(wrong.find("domain_id is " + std::to_string(d.domain_id)) != std::string::npos);
  CHECK(wrong.find("tandem keys") != std::string::npos);
  // The right domain: the check passes on to the next file (the CA here, which this test did not make).
  std::ofstream(dir + "/permissions.p7s") << permissions_xml(ids, d.domain_id, "2026-01-01T00:00:00",
                                                             "2036-01-01T00:00:00");
  CHECK(check_keys(d).find("grants domain") == std::string::npos);
  CHECK(check_keys(d).find("is missing") != std::string::npos);
  std::remove((dir + "/permissions.p7s").c_str());
  ::rmdir(dir.c_str());
}
