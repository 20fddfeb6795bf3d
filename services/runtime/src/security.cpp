#include "tandem/runtime/security.hpp"

#include <openssl/pem.h>
#include <openssl/x509.h>
#include <unistd.h>

#include <climits>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>

#include "tandem/dds/qos.hpp"
#include "tandem/sim/scenario_yaml.hpp"

namespace tandem::runtime {

namespace bus = tandem::dds;

std::string identity_name(const std::string& role, const std::string& module, const std::string& robot) {
  if (role == "robot") return "robot." + module + "." + robot;
  if (role == "world" || role == "supervisor" || role == "agent") return role + "." + module;  // agent: the host
  return role;  // coordinator, launcher, cli, recorder
}

std::vector<Identity> identities(const Deployment& d) {
  std::vector<Identity> out;
  const std::string status = bus::kStatusTopic, control = bus::kControlTopic, tasks = bus::kTaskAssignmentTopic,
                    states = bus::kTaskStateTopic, coord = bus::kCoordinatorStateTopic;
  for (const auto& m : d.modules) {
    const sim::Scenario sc = sim::load_scenario(m.scenario);
    const std::string plan = bus::module_topic(bus::kSupervisorPlanTopic, m.name);
    const std::string report = bus::module_topic(bus::kWorldReportTopic, m.name);
    Identity world{identity_name("world", m.name), {status, report, bus::kWorldSummaryTopic}, {plan}};
    for (const auto& r : sc.robots) {
      const std::string arm = m.name + "/" + r.name;
      world.publish.push_back(bus::arm_topic(bus::kSensorsTopic, arm));
      world.subscribe.push_back(bus::arm_topic(bus::kTorquesTopic, arm));
      // A robot writes torques for its own arm only, and reads only its own arm's sensors.
      out.push_back({identity_name("robot", m.name, r.name),
                     {status, bus::arm_topic(bus::kTorquesTopic, arm), bus::kRobotSummaryTopic},
                     {bus::arm_topic(bus::kSensorsTopic, arm), plan}});
    }
    out.push_back(world);
    out.push_back({identity_name("supervisor", m.name), {status, plan, states}, {report, tasks, control, plan}});
  }
  out.push_back({"coordinator", {status, tasks, coord}, {states, status, coord}});
  // The launcher and the CLI are the only writers of control requests (the launcher asks supervisors to pause,
  // resume and drain, and republishes the coordinator's state for a successor).
  out.push_back({"launcher",
                 {status, control, coord, bus::kAgentRequestTopic},
                 {bus::kRobotSummaryTopic, bus::kWorldSummaryTopic, status, control, states, coord, bus::kAgentStateTopic}});
  // Multi-host: each host's agent reads the launcher's requests (and the agents' states: one agent per host), and
  // writes its own state and status.
  for (const auto& h : d.hosts) {
    out.push_back({identity_name("agent", h.name), {bus::kAgentStateTopic, status}, {bus::kAgentRequestTopic, bus::kAgentStateTopic}});
  }
  out.push_back({"cli", {control}, {status}});
  // The recorder reads everything and writes only its status.
  out.push_back({"recorder", {status}, {"tandem/*"}});
  return out;
}

bool per_tick_local(const Deployment& d) { return d.hosts.empty() && d.transport == "shm"; }

std::string governance_xml(const Deployment& d) {
  auto rule = [](const std::string& topic, bool discovery, const char* protection) {
    return std::string("        <topic_rule>\n          <topic_expression>") + topic + "</topic_expression>\n"
           "          <enable_discovery_protection>" + (discovery ? "true" : "false") + "</enable_discovery_protection>\n"
           "          <enable_liveliness_protection>false</enable_liveliness_protection>\n"
           "          <enable_read_access_control>true</enable_read_access_control>\n"
           "          <enable_write_access_control>true</enable_write_access_control>\n"
           "          <metadata_protection_kind>" + protection + "</metadata_protection_kind>\n"
           "          <data_protection_kind>" + protection + "</data_protection_kind>\n"
           "        </topic_rule>\n";
  };
  std::ostringstream x;
  x << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
       "<!-- tandem: made by `tandem keys` from the deployment (docs/security.md). -->\n"
       "<dds xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
       "xsi:noNamespaceSchemaLocation=\"http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd\">\n"
       "  <domain_access_rules>\n"
       "    <domain_rule>\n"
       "      <domains><id>" << d.domain_id << "</id></domains>\n"
       "      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>\n"
       "      <enable_join_access_control>true</enable_join_access_control>\n"
       "      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>\n"
       "      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>\n"
       "      <rtps_protection_kind>NONE</rtps_protection_kind>\n"
       "      <topic_access_rules>\n";
  if (per_tick_local(d)) {
    // The first matching rule applies: the per-tick topics of a one-host shared-memory deployment (access
    // control only; their samples never leave shared memory), then everything else (encrypted). By name, arm by
    // arm: Fast DDS matches topic expressions like file names, where '*' does not cross a '/'.
    for (const auto& m : d.modules) {
      for (const auto& r : sim::load_scenario(m.scenario).robots) {
        const std::string arm = m.name + "/" + r.name;
        x << rule(bus::arm_topic(bus::kSensorsTopic, arm), true, "NONE") << rule(bus::arm_topic(bus::kTorquesTopic, arm), true, "NONE");
      }
    }
  }
  x << rule("*", true, "ENCRYPT");
  x << "      </topic_access_rules>\n"
       "    </domain_rule>\n"
       "  </domain_access_rules>\n"
       "</dds>\n";
  return x.str();
}

std::string permissions_xml(const std::vector<Identity>& ids, int domain_id, const std::string& not_before,
                            const std::string& not_after) {
  std::ostringstream x;
  x << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
       "<!-- tandem: made by `tandem keys` from the deployment (docs/security.md). -->\n"
       "<dds xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
       "xsi:noNamespaceSchemaLocation=\"http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd\">\n"
       "  <permissions>\n";
  auto topics = [&](const char* what, const std::vector<std::string>& list) {
    if (list.empty()) return;
    x << "        <" << what << ">\n          <topics>\n";
    for (const auto& t : list) x << "            <topic>" << t << "</topic>\n";
    x << "          </topics>\n        </" << what << ">\n";
  };
  for (const auto& id : ids) {
    x << "    <grant name=\"" << id.name << "\">\n"
      << "      <subject_name>CN=" << id.name << "</subject_name>\n"
      << "      <validity><not_before>" << not_before << "</not_before><not_after>" << not_after
      << "</not_after></validity>\n"
      << "      <allow_rule>\n        <domains><id>" << domain_id << "</id></domains>\n";
    topics("publish", id.publish);
    topics("subscribe", id.subscribe);
    x << "      </allow_rule>\n      <default>DENY</default>\n    </grant>\n";
  }
  x << "  </permissions>\n</dds>\n";
  return x.str();
}

std::string missing_key_file(const std::string& dir, const std::string& name) {
  for (const std::string& f : std::vector<std::string>{"ca.pem", "governance.p7s", "permissions.p7s", name + ".pem", name + ".key"}) {
    std::string p = dir + "/" + f;
    if (::access(p.c_str(), R_OK) != 0) return p;
  }
  return "";
}

std::string certificate_problem(const std::string& path) {
  // OpenSSL's X509 API, not the openssl command: a quote in a path cannot break it, and nothing is spawned.
  std::FILE* f = std::fopen(path.c_str(), "r");
  if (f == nullptr) return "cannot be read";
  X509* x = PEM_read_X509(f, nullptr, nullptr, nullptr);
  std::fclose(f);
  if (x == nullptr) return "is not a PEM certificate";
  // X509_cmp_current_time: -1 if the time is before now, 1 if after, 0 on error.
  const int not_after = X509_cmp_current_time(X509_get0_notAfter(x));
  const int not_before = X509_cmp_current_time(X509_get0_notBefore(x));
  X509_free(x);
  if (not_after <= 0) return not_after == 0 ? "has an unreadable validity" : "has expired";
  if (not_before >= 0) return not_before == 0 ? "has an unreadable validity" : "is not valid yet";
  return "";
}

namespace {
// The permissions grant one domain: keys made before domain_id changed would refuse every topic at run time.
std::string domain_problem(const Deployment& d) {
  const std::string perms = d.security_keys + "/permissions.p7s";
  std::ifstream in{perms};
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string tag = "<domains><id>";
  for (size_t at = text.find(tag); at != std::string::npos; at = text.find(tag, at + 1)) {
    const size_t begin = at + tag.size();
    const std::string id = text.substr(begin, text.find('<', begin) - begin);
    if (id != std::to_string(d.domain_id)) {
      return "security: " + perms + " grants domain " + id + ", but the deployment's domain_id is " +
             std::to_string(d.domain_id);
    }
  }
  return "";
}
}  // namespace

std::string check_keys(const Deployment& d) {
  if (d.security_keys.empty()) return "";
  const std::string remake = "; make the keys with `tandem keys " + d.source + "`";
  if (const std::string wrong = domain_problem(d); !wrong.empty()) return wrong + remake;
  for (const auto& id : identities(d)) {
    const std::string missing = missing_key_file(d.security_keys, id.name);
    if (!missing.empty()) return "security: " + missing + " is missing (identity '" + id.name + "')" + remake;
    const std::string cert = d.security_keys + "/" + id.name + ".pem";
    const std::string problem = certificate_problem(cert);
    if (!problem.empty()) return "security: " + cert + " " + problem + " (identity '" + id.name + "')" + remake;
  }
  return "";
}

std::string use_security(const Deployment& d, const std::string& name) {
  if (d.security_keys.empty()) return "";
  const std::string missing = missing_key_file(d.security_keys, name);
  if (!missing.empty()) {
    return "security: " + missing + " is missing (identity '" + name + "'); make the keys with `tandem keys " +
           d.source + "`";
  }
  if (const std::string wrong = domain_problem(d); !wrong.empty()) {
    return wrong + "; make the keys with `tandem keys " + d.source + "`";
  }
  // Absolute: Fast DDS takes the files as file: URIs, and children may run elsewhere.
  char* abs = ::realpath(d.security_keys.c_str(), nullptr);
  const std::string dir = abs != nullptr ? abs : d.security_keys;
  std::free(abs);
  ::setenv("TANDEM_SECURITY_DIR", dir.c_str(), 1);
  ::setenv("TANDEM_IDENTITY", name.c_str(), 1);
  // Secured participants discover each other by unicast only (services/dds/src/participant.cpp): every host of
  // the deployment, or this machine.
  std::string peers;
  for (const auto& h : d.hosts) peers += (peers.empty() ? "" : ",") + h.address;
  ::setenv("TANDEM_DDS_PEERS", peers.empty() ? "127.0.0.1" : peers.c_str(), 1);
  return "";
}

}  // namespace tandem::runtime
