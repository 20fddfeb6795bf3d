#include "tandem/runtime/deployment.hpp"

#include <arpa/inet.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <unordered_set>

#include "tandem/sim/module_setup.hpp"
#include "tandem/sim/scenario_yaml.hpp"
#include "tandem/sim/yaml_reader.hpp"

namespace tandem::runtime {

namespace {
bool ipv4(const std::string& text) {
  in_addr a{};
  return ::inet_pton(AF_INET, text.c_str(), &a) == 1;
}

/// A host key (`host:`, `supervisor_host:`, ...): a name of `hosts:`; "" if the key is absent.
std::string read_host(sim::yaml::MapReader& r, const YAML::Node& node, const std::string& key, const Deployment& d) {
  std::string h;
  r.text(key, h);
  if (!r.has(key)) return "";
  if (d.hosts.empty()) r.fail(node[key], r.key_path(key), "placing a process on a host needs a top-level 'hosts:' list");
  if (find_host(d, h) == nullptr) {
    std::string list;
    for (const auto& x : d.hosts) list += (list.empty() ? "" : ", ") + x.name;
    r.fail(node[key], r.key_path(key), "unknown host '" + h + "'; hosts: " + list);
  }
  return h;
}

/// robot_hosts / standby_hosts: {robot: host}.
std::map<std::string, std::string> read_robot_hosts(sim::yaml::MapReader& r, const YAML::Node& node,
                                                    const std::string& key, const Deployment& d) {
  std::map<std::string, std::string> out;
  if (!r.has(key)) return out;
  sim::yaml::MapReader m = r.child(key);
  for (const auto& kv : node[key]) {
    const std::string robot = kv.first.Scalar();
    out[robot] = read_host(m, node[key], robot, d);
  }
  m.finish();
  return out;
}
}  // namespace

const HostSpec* find_host(const Deployment& d, const std::string& name) {
  for (const auto& h : d.hosts) {
    if (h.name == name) return &h;
  }
  return nullptr;
}

std::string coordinator_host_of(const Deployment& d, bool standby) {
  return standby && !d.coordinator_standby_host.empty() ? d.coordinator_standby_host : d.coordinator_host;
}

std::string host_of(const ModuleDeployment& m, const std::string& role, const std::string& slot, bool standby) {
  auto pick = [&](const std::string& h) { return h.empty() ? m.host : h; };
  if (role == "supervisor") return pick(standby && !m.supervisor_standby_host.empty() ? m.supervisor_standby_host : m.supervisor_host);
  if (role == "robot") {
    const auto& map = standby ? m.standby_hosts : m.robot_hosts;
    const auto it = map.find(slot);
    if (it != map.end()) return it->second;
    if (standby) {  // a standby without its own host: on its primary's
      const auto p = m.robot_hosts.find(slot);
      if (p != m.robot_hosts.end()) return p->second;
    }
    return m.host;
  }
  return m.host;  // world
}

Deployment load_deployment(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw sim::ConfigError(path + ": cannot open the deployment file");
  std::stringstream ss;
  ss << in.rdbuf();
  YAML::Node root;
  try {
    root = YAML::Load(ss.str());
  } catch (const YAML::Exception& e) {
    throw sim::ConfigError(path + ":" + std::to_string(e.mark.line + 1) + ": invalid YAML: " + e.msg);
  }
  if (!root || root.IsNull()) throw sim::ConfigError(path + ": the file is empty; expected a deployment mapping");
  Deployment d;
  d.source = path;
  const std::string dir = path.find('/') == std::string::npos ? "." : path.substr(0, path.rfind('/'));
  sim::yaml::MapReader top(root, "", path);
  top.text("name", d.name, true);
  int domain = 0;
  top.integer("domain_id", domain, 0, 232, true);
  d.domain_id = domain;
  top.choice("transport", d.transport, {"shm", "udp"});
  top.choice("timing", d.timing, {"lockstep", "realtime"});
  top.num("timeout", d.timeout, 0.1, 3600.0);
  top.num("start_timeout", d.start_timeout, 1.0, 3600.0);
  top.integer("realtime_priority", d.realtime_priority, 0, 98);
  top.choice("cpu_affinity", d.cpu_affinity, {"module", "none"});
  top.num("spin_limit", d.spin_limit, 0.0, 1.0);
  top.boolean("overload_brake", d.overload_brake);
  top.boolean("shed_modules", d.shed_modules);
  top.boolean("test_no_brakes", d.test_no_brakes);
  top.choice("discovery", d.discovery, {"simple", "server"});
  top.integer("discovery_port", d.discovery_port, 1024, 65535);
  top.text("discovery_address", d.discovery_address);
  if (!ipv4(d.discovery_address)) {
    top.fail(root["discovery_address"], "discovery_address",
             "expected an IPv4 address (the Discovery Server's), got '" + d.discovery_address + "'");
  }
  top.choice("discovery_start", d.discovery_start, {"launcher", "external"});
  if (top.has("discovery_servers")) {
    top.choice("discovery_servers", d.discovery_servers, {"module", "one"});
    if (d.discovery_servers == "module" && d.discovery_start == "external") {
      top.fail(root["discovery_servers"], "discovery_servers",
               "module (one server per module) needs discovery_start: launcher; an external Discovery Server is one "
               "server (discovery_servers: one)");
    }
  } else if (d.discovery_start == "external") {
    d.discovery_servers = "one";
  }
  if (top.has("module_start")) top.choice("module_start", d.module_start, {"together", "one_by_one"});
  top.num("host_timeout", d.host_timeout, 0.2, 60.0);
  if (top.has("hosts")) {
    sim::yaml::MapReader hr = top.child("hosts");
    for (const auto& kv : root["hosts"]) {
      HostSpec h;
      h.name = kv.first.Scalar();
      if (h.name.empty() || h.name.find_first_of("/ ,") != std::string::npos) {
        hr.fail(kv.first, hr.key_path(h.name), "host names must be non-empty, without '/', ',' or spaces");
      }
      sim::yaml::MapReader one = hr.child(h.name);
      one.text("address", h.address, true);
      if (!ipv4(h.address)) {
        one.fail(kv.second["address"], one.key_path("address"), "expected an IPv4 address, got '" + h.address + "'");
      }
      one.finish();
      for (const auto& o : d.hosts) {
        if (o.address == h.address) {
          one.fail(kv.second["address"], one.key_path("address"), "hosts '" + o.name + "' and '" + h.name + "' have the same address " + h.address);
        }
      }
      d.hosts.push_back(h);
    }
    hr.finish();
    if (d.hosts.empty()) top.fail(root["hosts"], "hosts", "list at least one host (name: {address: IPv4})");
    // A Discovery Server on a loopback address is out of reach of every other host.
    const bool spread = std::any_of(d.hosts.begin(), d.hosts.end(), [](const HostSpec& h) { return h.address.rfind("127.", 0) != 0; });
    if (d.discovery == "server" && d.discovery_address.rfind("127.", 0) == 0 && spread) {
      top.fail(root["discovery_address"] ? root["discovery_address"] : root["discovery"], "discovery_address",
               "the Discovery Server at " + d.discovery_address + " (loopback) cannot be reached from the other hosts; "
               "give an address every host reaches, e.g. one of hosts:");
    }
  }
  top.text("record", d.record);
  top.text("record_topics", d.record_topics);
  {
    std::stringstream groups(d.record_topics);
    std::string g;
    while (std::getline(groups, g, ',')) {
      bool known = g == "all";
      for (const char* k : kRecordGroups) known = known || g == k;
      if (!known) {
        top.fail(root["record_topics"], "record_topics",
                 "unknown topic group '" + g + "'; accepted: all, ticks, world, status, tasks, summaries, control, events");
      }
    }
  }
  YAML::Node mods = top.sequence("modules", true);
  std::set<std::string> names;
  for (size_t i = 0; i < mods.size(); ++i) {
    sim::yaml::MapReader mr(mods[i], "modules[" + std::to_string(i) + "]", path);
    ModuleDeployment m;
    mr.text("name", m.name, true);
    if (m.name.empty() || m.name.find('/') != std::string::npos || !names.insert(m.name).second) {
      mr.fail(mods[i]["name"], mr.key_path("name"), "module names must be unique, non-empty, without '/'");
    }
    mr.text("scenario", m.scenario, true);
    if (!m.scenario.empty() && m.scenario[0] != '/') m.scenario = dir + "/" + m.scenario;
    mr.text("case", m.case_name, true);
    mr.integer("standby", m.standby, 0, 3);
    mr.integer("supervisor_standby", m.supervisor_standby, 0, 3);
    mr.choice("restart", m.restart, {"never", "on-failure", "always"});
    mr.integer("restart_limit", m.restart_limit, 0, 100);
    mr.num("restart_window", m.restart_window, 0.1, 86400.0);
    mr.num("restart_backoff", m.restart_backoff, 0.0, 60.0);
    mr.choice("restart_as", m.restart_as, {"standby", "primary"});
    mr.boolean("autostart", m.autostart);
    m.host = read_host(mr, mods[i], "host", d);
    if (!d.hosts.empty() && m.host.empty()) {
      mr.fail(mods[i], mr.key_path("host"), "with 'hosts:', every module needs a host (its world's, and the default "
                                            "of its other processes)");
    }
    m.supervisor_host = read_host(mr, mods[i], "supervisor_host", d);
    m.supervisor_standby_host = read_host(mr, mods[i], "supervisor_standby_host", d);
    m.robot_hosts = read_robot_hosts(mr, mods[i], "robot_hosts", d);
    m.standby_hosts = read_robot_hosts(mr, mods[i], "standby_hosts", d);
    mr.finish();
    // Validate what each process will load, before anything starts.
    const sim::Scenario sc = sim::load_scenario(m.scenario);
    bool found = false;
    std::string list;
    for (const auto& c : sc.cases) {
      found = found || c.name == m.case_name;
      list += (list.empty() ? "" : ", ") + c.name;
    }
    if (!found) {
      mr.fail(mods[i]["case"], mr.key_path("case"), "no case '" + m.case_name + "' in " + m.scenario + "; cases: " + list);
    }
    for (const auto* placed : {&m.robot_hosts, &m.standby_hosts}) {
      for (const auto& [robot, host] : *placed) {
        bool known = false;
        std::string robots;
        for (const auto& r : sc.robots) {
          known = known || r.name == robot;
          robots += (robots.empty() ? "" : ", ") + r.name;
        }
        const char* key = placed == &m.robot_hosts ? "robot_hosts" : "standby_hosts";
        if (!known) {
          mr.fail(mods[i][key][robot], mr.key_path(std::string(key) + "." + robot),
                  "no robot '" + robot + "' in " + m.scenario + "; robots: " + robots);
        }
      }
    }
    d.modules.push_back(m);
  }
  if (d.modules.empty()) top.fail(mods, "modules", "list at least one module");
  if (d.module_start.empty()) d.module_start = d.discovery == "simple" && d.modules.size() > 2 ? "one_by_one" : "together";
  if (d.discovery == "server" && d.discovery_servers == "module") {
    // Server ids are a byte (Fast DDS's GUID prefix), and every port must be a port.
    const int last = discovery_servers(d).back().port;
    if (d.modules.size() > 256 || last > 65535) {
      top.fail(mods, "modules",
               std::to_string(d.modules.size()) + " modules need Discovery Server ports up to " + std::to_string(last) +
                   " (one server per module, " + std::to_string(kDiscoveryPortStride) +
                   " apart, at most 256): use discovery_servers: one, or a lower discovery_port");
    }
  }
  if (top.has("security")) {
    sim::yaml::MapReader se = top.child("security");
    se.text("keys", d.security_keys, true);
    if (d.security_keys.empty()) se.fail(root["security"]["keys"], "security.keys", "expected a directory (made by `tandem keys`)");
    if (d.security_keys[0] != '/') d.security_keys = dir + "/" + d.security_keys;
    se.finish();
    if (d.discovery == "server") {
      top.fail(root["security"], "security",
               "security with 'discovery: server' is not supported (the Fast DDS Discovery Server started by the "
               "launcher has no identity); use 'discovery: simple'");
    }
  }
  if (top.has("coordinator")) {
    sim::yaml::MapReader co = top.child("coordinator");
    d.coordinator = true;
    co.choice("balance", d.balance, {"wear", "round_robin"});
    co.integer("standby", d.coordinator_standby, 0, 3);
    co.choice("restart", d.coordinator_restart, {"never", "on-failure", "always"});
    co.integer("restart_limit", d.coordinator_restart_limit, 0, 100);
    d.coordinator_host = read_host(co, root["coordinator"], "host", d);
    d.coordinator_standby_host = read_host(co, root["coordinator"], "standby_host", d);
    if (!d.hosts.empty() && d.coordinator_host.empty()) {
      co.fail(root["coordinator"], "coordinator.host", "with 'hosts:', the coordinator needs a host");
    }
    co.num("restart_window", d.coordinator_restart_window, 0.1, 86400.0);
    YAML::Node tasks = co.sequence("tasks", true);
    // Names seen so far: a soak's hour derives some 12 000 tasks, and a pairwise check cost each coordinator start
    // (the soak restarts coordinators some 30 times an hour) most of a second of CPU at the control plane's priority.
    std::unordered_set<std::string> task_names;
    for (size_t i = 0; i < tasks.size(); ++i) {
      sim::yaml::MapReader tr(tasks[i], co.key_path("tasks[" + std::to_string(i) + "]"), path);
      TaskSpec t;
      tr.text("name", t.name, true);
      YAML::Node segs = tr.sequence("segments", true);
      for (size_t k = 0; k < segs.size(); ++k) {
        sim::yaml::MapReader sr(segs[k], tr.key_path("segments[" + std::to_string(k) + "]"), path);
        Eigen::Vector3d to = Eigen::Vector3d::Zero();
        double duration = 1.0;
        sr.vec<3>("to", to, -100.0, 100.0, true);
        sr.num("duration", duration, 1e-3, 3600.0, true);
        sr.finish();
        t.waypoints.insert(t.waypoints.end(), {to(0), to(1), to(2), duration});
      }
      if (t.waypoints.empty()) tr.fail(tasks[i], tr.key_path("segments"), "a task needs at least one segment");
      tr.finish();
      if (!task_names.insert(t.name).second) {
        tr.fail(tasks[i]["name"], tr.key_path("name"), "task names must be unique ('" + t.name + "' twice)");
      }
      d.tasks.push_back(t);
    }
    if (d.tasks.empty()) co.fail(tasks, co.key_path("tasks"), "list at least one task");
    co.finish();
    // Every waypoint must be reachable by every module's arms, on the way from any other waypoint or the
    // start: check the straight segments between all of them every 10 ms of their planned motion.
    for (const auto& m : d.modules) {
      const sim::Scenario sc = sim::load_scenario(m.scenario);
      std::vector<Eigen::Vector3d> poses{sc.start};
      for (const auto& t : d.tasks) {
        for (size_t w = 0; w + 3 < t.waypoints.size() + 0; w += 4) {
          const Eigen::Vector3d p(t.waypoints[w], t.waypoints[w + 1], t.waypoints[w + 2]);
          // Each distinct waypoint once: the check is quadratic in their number (long queues repeat a few).
          if (std::none_of(poses.begin(), poses.end(), [&](const Eigen::Vector3d& q) { return q == p; })) {
            poses.push_back(p);
          }
        }
      }
      for (const auto& a : poses) {
        for (const auto& b : poses) {
          sim::Scenario probe = sc;
          probe.start = a;
          probe.hold = 0.0;
          probe.segments = {model::ObjectPath::Segment{b, 1.0}};
          probe.duration = 1.0;
          try {
            for (const auto& c : probe.cases) {
              if (c.name == m.case_name) (void)sim::make_module(probe, c);
            }
          } catch (const std::exception& e) {
            co.fail(tasks, co.key_path("tasks"),
                    "module '" + m.name + "' cannot move the object between (" + std::to_string(a(0)) + ", " +
                        std::to_string(a(1)) + ") and (" + std::to_string(b(0)) + ", " + std::to_string(b(1)) + ")");
          }
        }
      }
    }
  }
  top.finish();
  return d;
}

const ModuleDeployment* find_module(const Deployment& d, const std::string& name) {
  for (const auto& m : d.modules) {
    if (m.name == name) return &m;
  }
  return nullptr;
}

namespace {
std::string absolute_path(const std::string& p) {
  if (p.empty()) return p;
  std::error_code ec;
  const std::filesystem::path abs = std::filesystem::absolute(p, ec);
  return ec ? p : abs.lexically_normal().string();
}
}  // namespace

std::string deployment_yaml(const Deployment& d) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);
  out << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << d.name;
  out << YAML::Key << "domain_id" << YAML::Value << d.domain_id;
  out << YAML::Key << "transport" << YAML::Value << d.transport;
  out << YAML::Key << "timing" << YAML::Value << d.timing;
  out << YAML::Key << "timeout" << YAML::Value << d.timeout;
  out << YAML::Key << "start_timeout" << YAML::Value << d.start_timeout;
  out << YAML::Key << "realtime_priority" << YAML::Value << d.realtime_priority;
  out << YAML::Key << "cpu_affinity" << YAML::Value << d.cpu_affinity;
  out << YAML::Key << "spin_limit" << YAML::Value << d.spin_limit;
  out << YAML::Key << "overload_brake" << YAML::Value << d.overload_brake;
  out << YAML::Key << "shed_modules" << YAML::Value << d.shed_modules;
  if (d.test_no_brakes) out << YAML::Key << "test_no_brakes" << YAML::Value << true;
  out << YAML::Key << "discovery" << YAML::Value << d.discovery;
  if (d.discovery_port > 0) out << YAML::Key << "discovery_port" << YAML::Value << d.discovery_port;
  out << YAML::Key << "discovery_address" << YAML::Value << d.discovery_address;
  out << YAML::Key << "discovery_start" << YAML::Value << d.discovery_start;
  out << YAML::Key << "discovery_servers" << YAML::Value << d.discovery_servers;
  if (!d.module_start.empty()) out << YAML::Key << "module_start" << YAML::Value << d.module_start;
  out << YAML::Key << "host_timeout" << YAML::Value << d.host_timeout;
  if (!d.hosts.empty()) {
    out << YAML::Key << "hosts" << YAML::Value << YAML::BeginMap;
    for (const HostSpec& h : d.hosts) {
      out << YAML::Key << h.name << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "address" << YAML::Value
          << h.address << YAML::EndMap;
    }
    out << YAML::EndMap;
  }
  if (!d.record.empty()) out << YAML::Key << "record" << YAML::Value << d.record;
  if (!d.record_topics.empty()) out << YAML::Key << "record_topics" << YAML::Value << d.record_topics;
  auto hosts_map = [&out](const char* key, const std::map<std::string, std::string>& m) {
    if (m.empty()) return;
    out << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginMap;
    for (const auto& [robot, host] : m) out << YAML::Key << robot << YAML::Value << host;
    out << YAML::EndMap;
  };
  out << YAML::Key << "modules" << YAML::Value << YAML::BeginSeq;
  for (const ModuleDeployment& m : d.modules) {
    out << YAML::BeginMap;
    out << YAML::Key << "name" << YAML::Value << m.name;
    out << YAML::Key << "scenario" << YAML::Value << absolute_path(m.scenario);
    out << YAML::Key << "case" << YAML::Value << m.case_name;
    out << YAML::Key << "standby" << YAML::Value << m.standby;
    out << YAML::Key << "supervisor_standby" << YAML::Value << m.supervisor_standby;
    out << YAML::Key << "restart" << YAML::Value << m.restart;
    out << YAML::Key << "restart_limit" << YAML::Value << m.restart_limit;
    out << YAML::Key << "restart_window" << YAML::Value << m.restart_window;
    out << YAML::Key << "restart_backoff" << YAML::Value << m.restart_backoff;
    out << YAML::Key << "restart_as" << YAML::Value << m.restart_as;
    out << YAML::Key << "autostart" << YAML::Value << m.autostart;
    if (!m.host.empty()) out << YAML::Key << "host" << YAML::Value << m.host;
    if (!m.supervisor_host.empty()) out << YAML::Key << "supervisor_host" << YAML::Value << m.supervisor_host;
    if (!m.supervisor_standby_host.empty()) {
      out << YAML::Key << "supervisor_standby_host" << YAML::Value << m.supervisor_standby_host;
    }
    hosts_map("robot_hosts", m.robot_hosts);
    hosts_map("standby_hosts", m.standby_hosts);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (!d.security_keys.empty()) {
    out << YAML::Key << "security" << YAML::Value << YAML::BeginMap << YAML::Key << "keys" << YAML::Value
        << absolute_path(d.security_keys) << YAML::EndMap;
  }
  if (d.coordinator) {
    out << YAML::Key << "coordinator" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "balance" << YAML::Value << d.balance;
    out << YAML::Key << "standby" << YAML::Value << d.coordinator_standby;
    out << YAML::Key << "restart" << YAML::Value << d.coordinator_restart;
    out << YAML::Key << "restart_limit" << YAML::Value << d.coordinator_restart_limit;
    out << YAML::Key << "restart_window" << YAML::Value << d.coordinator_restart_window;
    if (!d.coordinator_host.empty()) out << YAML::Key << "host" << YAML::Value << d.coordinator_host;
    if (!d.coordinator_standby_host.empty()) out << YAML::Key << "standby_host" << YAML::Value << d.coordinator_standby_host;
    out << YAML::Key << "tasks" << YAML::Value << YAML::BeginSeq;
    for (const TaskSpec& t : d.tasks) {
      out << YAML::BeginMap << YAML::Key << "name" << YAML::Value << t.name << YAML::Key << "segments" << YAML::Value
          << YAML::BeginSeq;
      for (size_t w = 0; w + 3 < t.waypoints.size(); w += 4) {
        out << YAML::Flow << YAML::BeginMap << YAML::Key << "to" << YAML::Value << YAML::Flow
            << std::vector<double>{t.waypoints[w], t.waypoints[w + 1], t.waypoints[w + 2]} << YAML::Key << "duration"
            << YAML::Value << t.waypoints[w + 3] << YAML::EndMap;
      }
      out << YAML::EndSeq << YAML::EndMap;
    }
    out << YAML::EndSeq << YAML::EndMap;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

std::vector<DiscoveryServer> discovery_servers(const Deployment& d) {
  std::vector<DiscoveryServer> out;
  if (d.discovery != "server") return out;
  if (d.discovery_servers != "module") {
    out.push_back({0, d.discovery_address, discovery_port_of(d), ""});
    return out;
  }
  // Slot j at discovery_port_of + j * stride, skipping a slot inside the deployment's own RTPS ports (Fast DDS's
  // default mapping: 7400 + 250 domain, 250 ports; with the default base that is domain 18 + j or so): a server
  // there would take a port one of the deployment's participants may need.
  const int rtps_lo = 7400 + 250 * static_cast<int>(d.domain_id), rtps_hi = rtps_lo + 250;
  int slot = 0;
  for (size_t i = 0; i < d.modules.size(); ++i) {
    int port = discovery_port_of(d) + slot * kDiscoveryPortStride;
    while (slot > 0 && port >= rtps_lo && port < rtps_hi) port = discovery_port_of(d) + ++slot * kDiscoveryPortStride;
    ++slot;
    out.push_back({static_cast<int>(i), d.discovery_address, port, d.modules[i].name});
  }
  return out;
}

std::string discovery_env(const Deployment& d, const std::string& module) {
  // A client names server k by its place in the list: k ';' before it (empty places are no server).
  std::string out;
  int place = 0;
  for (const DiscoveryServer& s : discovery_servers(d)) {
    if (!module.empty() && !s.module.empty() && s.module != module) continue;
    for (; place < s.id; ++place) out += ';';
    out += s.address + ":" + std::to_string(s.port);
  }
  return out;
}

std::string discovery_text(const Deployment& d) {
  const auto servers = discovery_servers(d);
  if (servers.empty()) return "simple";
  std::string out = servers.front().address + ":" + std::to_string(servers.front().port);
  if (servers.size() > 1) {
    out += " and " + std::to_string(servers.size() - 1) + " more (one server per module, ports " +
           std::to_string(kDiscoveryPortStride) + " apart)";
  }
  return out;
}

}  // namespace tandem::runtime
