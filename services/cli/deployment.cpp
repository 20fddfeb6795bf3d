#include "deployment.hpp"

#include <fstream>
#include <set>
#include <sstream>

#include "tandem/sim/scenario_yaml.hpp"
#include "tandem/sim/yaml_reader.hpp"

namespace tandem::cli {

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
    d.modules.push_back(m);
  }
  if (d.modules.empty()) top.fail(mods, "modules", "list at least one module");
  top.finish();
  return d;
}

}  // namespace tandem::cli
