#include "tandem/sim/scenario_yaml.hpp"

#include <yaml-cpp/yaml.h>

#include "tandem/sim/yaml_reader.hpp"

#include <cctype>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <set>
#include <sstream>

namespace tandem::sim {
namespace {

using yaml::kInf;
using yaml::kPositive;
using yaml::MapReader;

constexpr double kPos = kPositive;

void read_arm(MapReader r, model::ArmParams& a) {
  if (YAML::Node n = r.take("gamma", false)) {
    const auto g = r.vector_of<6>(n, r.key_path("gamma"), kPos, kInf);
    for (int i = 0; i < 6; ++i) a.gamma[static_cast<size_t>(i)] = g(i);
  }
  r.vec<3>("link_length", a.link_length, kPos, 10.0);
  r.vec<3>("viscous", a.viscous, 0.0, kInf);
  r.vec<3>("coulomb", a.coulomb, 0.0, kInf);
  r.num("coulomb_band", a.coulomb_band, 0.0, 10.0);
  r.vec<3>("q_min", a.q_min, -2 * model::kPi, 2 * model::kPi);
  r.vec<3>("q_max", a.q_max, -2 * model::kPi, 2 * model::kPi);
  r.vec<3>("tau_max", a.tau_max, kPos, kInf);
  r.finish();
  for (int i = 0; i < 3; ++i) {
    if (a.q_min(i) >= a.q_max(i)) {
      r.fail(YAML::Node(), r.key_path("q_min"), "q_min must be below q_max for every joint");
    }
  }
}

/// `key`: a list of exactly the chain's joint count of numbers in [lo, hi], into out[0..dof).
void joint_list(MapReader& r, const std::string& key, int dof, std::array<double, model::kMaxJoints>& out, double lo,
                double hi) {
  YAML::Node n = r.take(key, false);
  if (!n) return;
  if (!n.IsSequence() || n.size() != static_cast<size_t>(dof)) {
    std::ostringstream what;
    what << "expected a list of " << dof << " numbers (one per joint of this type)";
    if (lo > -kInf || hi < kInf) what << " in [" << lo << ", " << hi << "]";
    r.fail(n, r.key_path(key), what.str());
  }
  for (int i = 0; i < dof; ++i) {
    out[static_cast<size_t>(i)] = r.number(n[static_cast<size_t>(i)], r.key_path(key) + "[" + std::to_string(i) + "]", lo, hi);
  }
}

/// A chain type's `arm:` keys: every list has one entry per joint. Limits are in rad (revolute) or m (prismatic);
/// efforts in N m or N. A link length or mass given recomputes that body's centre (mid-link) and inertia (a rod).
void read_chain(MapReader r, model::ChainParams& c) {
  model::JointSpace& js = c.joints;
  const int n = js.dof;
  joint_list(r, "q_min", n, js.q_min, -10.0, 10.0);
  joint_list(r, "q_max", n, js.q_max, -10.0, 10.0);
  joint_list(r, "effort_max", n, js.effort_max, kPos, kInf);
  joint_list(r, "viscous", n, js.viscous, 0.0, kInf);
  joint_list(r, "coulomb", n, js.coulomb, 0.0, kInf);
  r.num("coulomb_band", js.coulomb_band, 0.0, 10.0);
  std::array<double, model::kMaxJoints> length{}, mass{};
  for (int i = 0; i < n; ++i) {
    length[static_cast<size_t>(i)] = c.bodies[static_cast<size_t>(i)].length;
    mass[static_cast<size_t>(i)] = c.bodies[static_cast<size_t>(i)].mass;
  }
  const bool geometry = r.has("link_length") || r.has("mass");
  joint_list(r, "link_length", n, length, 0.0, 10.0);
  joint_list(r, "mass", n, mass, kPos, 1e4);
  r.finish();
  for (int i = 0; i < n; ++i) {
    const auto ui = static_cast<size_t>(i);
    if (js.q_min[ui] >= js.q_max[ui]) r.fail(YAML::Node(), r.key_path("q_min"), "q_min must be below q_max for every joint");
    model::ChainBody& b = c.bodies[ui];
    if (b.joint == model::JointType::Prismatic && length[ui] != 0.0) {
      r.fail(YAML::Node(), r.key_path("link_length"),
             "joint " + std::to_string(i) + " is prismatic: its link_length must be 0 (the carriage has no link)");
    }
    if (b.joint == model::JointType::Revolute && length[ui] <= 0.0) {
      r.fail(YAML::Node(), r.key_path("link_length"), "joint " + std::to_string(i) + " is revolute: its link_length must be > 0");
    }
    if (geometry) {
      b.length = length[ui];
      b.mass = mass[ui];
      b.com = 0.5 * b.length;
      b.inertia = b.mass * b.length * b.length / 12.0;
    }
  }
}

void read_controller(MapReader r, ControllerConfig& c) {
  std::string law = "sliding_mode";
  r.choice("law", law, {"sliding_mode", "boundary_layer", "super_twisting", "pd"}, true);
  c.law.type = law == "pd"               ? model::LawType::PD
               : law == "boundary_layer" ? model::LawType::BoundaryLayer
               : law == "super_twisting" ? model::LawType::SuperTwisting
                                         : model::LawType::SlidingMode;
  // Position gains per contact-frame axis (tangent, approach, orientation); force gains on the force axis.
  r.vec_or_scalar<3>("K_p", c.law.K_p, 0.0, kInf);
  r.num("K_h", c.law.K_h, 0.0, kInf);
  r.vec_or_scalar<3>("m_p", c.law.m_p, kPos, kInf);
  r.num("m_h", c.law.m_h, kPos, kInf);
  r.vec_or_scalar<3>("boundary_p", c.law.phi_p, kPos, kInf);
  r.num("boundary_h", c.law.phi_h, kPos, kInf);
  r.vec_or_scalar<3>("kp_p", c.law.kp_p, 0.0, kInf);
  r.vec_or_scalar<3>("kd_p", c.law.kd_p, 0.0, kInf);
  r.num("kp_h", c.law.kp_h, 0.0, kInf);
  r.num("kd_h", c.law.kd_h, 0.0, kInf);
  r.boolean("feedforward_position", c.feedforward_position);
  r.boolean("feedforward_force", c.feedforward_force);
  r.num("reaching_gain_factor", c.reaching_gain_factor, 0.0, 100.0);
  r.num("reaching_margin", c.reaching_margin, 0.0, kInf);
  {
    MapReader comp = r.child("compensation");
    comp.boolean("coriolis", c.comp.coriolis);
    comp.boolean("gravity", c.comp.gravity);
    comp.boolean("viscous", c.comp.viscous);
    comp.boolean("coulomb", c.comp.coulomb);
    comp.num("coulomb_band", c.comp.coulomb_band, 0.0, 10.0);
    comp.boolean("contact_force", c.comp.contact_force);
    comp.finish();
  }
  r.finish();
}

Scenario read(const YAML::Node& root, const std::string& file) {
  Scenario s;
  s.source = file;
  MapReader top(root, "", file);
  top.text("name", s.name, true);
  for (char ch : s.name) {
    if (!(std::isalnum(static_cast<unsigned char>(ch)) || ch == '-' || ch == '_' || ch == '.') || s.name[0] == '.') {
      top.fail(root["name"], "name", "expected letters, digits, '-', '_' or '.' (not first); it names the output directory");
    }
  }
  {
    MapReader t = top.child("timing");
    t.num("period", s.period, 1e-5, 0.1);
    t.integer("substeps", s.substeps, 1, 1000);
    t.num("duration", s.duration, kPos, 3600.0);
    t.num("transient", s.transient, 0.0, 3600.0);
    t.finish();
  }
  {
    MapReader m = top.child("module", true);
    m.num("base_distance", s.base_distance, kPos, 100.0);
    m.num("base_height", s.base_height, -100.0, 100.0);
    m.num("grasp_safety_factor", s.grasp_safety_factor, 1.0, 100.0);
    m.num("gravity", s.g0, 0.0, 100.0);
    YAML::Node robots = m.sequence("robots", true);
    if (robots.size() != 2) m.fail(robots, m.key_path("robots"), "a basic module has exactly 2 robots");
    for (size_t j = 0; j < 2; ++j) {
      MapReader rr(robots[j], m.key_path("robots[" + std::to_string(j) + "]"), file);
      RobotConfig& rc = s.robots[j];
      rr.text("name", rc.name, true);
      bool name_ok = !rc.name.empty() && rc.name != "world" && rc.name != "supervisor";
      for (char ch : rc.name) name_ok = name_ok && (std::islower(static_cast<unsigned char>(ch)) || std::isdigit(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-');
      if (!name_ok) {
        rr.fail(robots[j]["name"], rr.key_path("name"),
                "expected lower-case letters, digits, '_' or '-', and not 'world' or 'supervisor' (it names processes)");
      }
      rr.num("elbow", rc.elbow, -1.0, 1.0);
      if (rc.elbow != -1.0 && rc.elbow != 1.0) rr.fail(robots[j]["elbow"], rr.key_path("elbow"), "expected -1 or 1");
      rr.vec<3>("selection_p", rc.selection_p, 0.0, 1.0);
      // Only the approach axis has a force loop (eq. 17): the tangent and orientation are position-controlled.
      if (rc.selection_p != model::Vec3(1, 1, 1) && rc.selection_p != model::Vec3(1, 0, 1)) {
        rr.fail(robots[j]["selection_p"], rr.key_path("selection_p"),
                "expected [1, 0, 1] (hybrid: force on the approach axis, eq. 17) or [1, 1, 1] (position only)");
      }
      std::string type = model::arm_kind_name(model::ArmKind::Planar3R);
      rr.choice("type", type,
                {model::arm_kind_name(model::ArmKind::Planar3R), model::arm_kind_name(model::ArmKind::CartesianPPR),
                 model::arm_kind_name(model::ArmKind::Planar4R)});
      (void)model::parse_arm_kind(type, rc.type);
      if (rc.type == model::ArmKind::Planar3R) {
        std::string model_name = "smart3s2";
        rr.choice("model", model_name, {"smart3s2"});
        rc.arm = model::smart3s2();
        read_arm(rr.child("arm"), rc.arm);
        if (rr.has("posture")) {
          rr.fail(robots[j]["posture"], rr.key_path("posture"),
                  "only a cartesian_ppr or planar_4r takes a posture (the planar_3r's inverse kinematics is closed-form: "
                  "'elbow' picks its branch)");
        }
      } else {
        if (rr.has("model")) {
          rr.fail(robots[j]["model"], rr.key_path("model"), "'model' names an identified planar_3r (smart3s2); a " + type +
                                                               " takes its parameters under 'arm'");
        }
        rc.chain = rc.type == model::ArmKind::CartesianPPR ? model::cartesian_ppr() : model::planar_4r();
        read_chain(rr.child("arm"), rc.chain);
        rc.posture_given = rr.has("posture");
        joint_list(rr, "posture", rc.chain.joints.dof, rc.chain.joints.home, -10.0, 10.0);
      }
      rr.finish();
    }
    if (s.robots[0].name == s.robots[1].name) {
      m.fail(robots[1]["name"], m.key_path("robots[1].name"), "robot names must be unique");
    }
    {
      MapReader o = m.child("object", true);
      o.num("mass", s.object.mass, kPos, 1e4, true);
      o.num("half_width", s.object.half_width, kPos, 10.0);
      o.num("half_height", s.object.half_height, kPos, 10.0);
      o.num("inertia", s.object.inertia, 0.0, 1e6);
      o.num("mu_s", s.object.mu_s, kPos, 10.0, true);
      o.num("mu_k", s.object.mu_k, 0.0, 10.0);
      o.finish();
      if (s.object.mu_k > s.object.mu_s) {
        o.fail(YAML::Node(), o.key_path("mu_k"), "kinetic friction mu_k must not exceed mu_s");
      }
    }
    {
      MapReader c = m.child("contact");
      c.num("k_normal", s.contact.k_normal, kPos, 1e9);
      c.num("d_normal", s.contact.d_normal, 0.0, 1e7);
      c.num("k_tangent", s.contact.k_tangent, kPos, 1e9);
      c.num("d_tangent", s.contact.d_tangent, 0.0, 1e7);
      c.finish();
    }
    m.finish();
  }
  {
    MapReader t = top.child("task", true);
    t.vec<3>("start", s.start, -100.0, 100.0, true);
    t.num("hold", s.hold, 0.0, 3600.0);
    YAML::Node segs = t.sequence("segments", true);
    for (size_t i = 0; i < segs.size(); ++i) {
      MapReader sr(segs[i], t.key_path("segments[" + std::to_string(i) + "]"), file);
      model::ObjectPath::Segment seg;
      sr.vec<3>("to", seg.to, -100.0, 100.0, true);
      sr.num("duration", seg.duration, 1e-3, 3600.0, true);
      sr.finish();
      s.segments.push_back(seg);
    }
    t.finish();
  }
  {
    MapReader c = top.child("controllers", true);
    for (const auto& kv : root["controllers"]) {
      ControllerConfig cc;
      cc.name = kv.first.Scalar();
      c.take(cc.name, true);
      read_controller(MapReader(kv.second, c.key_path(cc.name), file), cc);
      s.controllers.push_back(cc);
    }
    if (s.controllers.empty()) c.fail(root["controllers"], "controllers", "define at least one controller");
  }
  {
    YAML::Node cases = top.sequence("cases", true);
    for (size_t i = 0; i < cases.size(); ++i) {
      MapReader cr(cases[i], "cases[" + std::to_string(i) + "]", file);
      CaseConfig cc;
      cr.text("name", cc.name, true);
      cr.text("controller", cc.controller, true);
      cr.boolean("disturbance", cc.disturbance);
      cr.num("disturbance_scale", cc.disturbance_scale, 0.0, 100.0);
      cr.boolean("require_grasp", cc.require_grasp);
      cr.choice("paper_case", cc.paper_case, {"PD", "PD^u", "SM", "SM^u"});
      if (s.find_controller(cc.controller) == nullptr) {
        std::string list;
        for (const auto& c : s.controllers) list += (list.empty() ? "" : ", ") + c.name;
        cr.fail(cases[i]["controller"], cr.key_path("controller"),
                "unknown controller '" + cc.controller + "'; defined: " + list);
      }
      cr.finish();
      for (const auto& other : s.cases) {
        if (file_name(other.name) == file_name(cc.name)) {
          cr.fail(cases[i]["name"], cr.key_path("name"),
                  "case name clashes with '" + other.name + "' (names must differ after mapping to file names)");
        }
      }
      s.cases.push_back(cc);
    }
    if (s.cases.empty()) top.fail(cases, "cases", "define at least one case");
  }
  {
    YAML::Node d = top.sequence("disturbed_robots", false);
    if (d) {
      s.disturbed_robots.clear();
      for (size_t i = 0; i < d.size(); ++i) {
        std::string n = d[i].IsScalar() ? d[i].Scalar() : "";
        int idx = n == s.robots[0].name ? 0 : n == s.robots[1].name ? 1 : -1;
        if (idx < 0) {
          top.fail(d[i], "disturbed_robots[" + std::to_string(i) + "]",
                   "unknown robot '" + n + "'; robots: " + s.robots[0].name + ", " + s.robots[1].name);
        }
        s.disturbed_robots.push_back(idx);
      }
    }
  }
  {
    std::string rep = s.robots[1].name;
    top.choice("report_robot", rep, {s.robots[0].name, s.robots[1].name});
    s.report_robot = rep == s.robots[0].name ? 0 : 1;
  }
  top.finish();
  if (s.transient >= s.duration) top.fail(root["timing"], "timing.transient", "must be shorter than timing.duration");
  return s;
}

}  // namespace

std::string file_name(const std::string& case_name) {
  std::string out;
  for (char ch : case_name) out += (std::isalnum(static_cast<unsigned char>(ch)) || ch == '-') ? ch : '_';
  return out;
}


Scenario parse_scenario(const std::string& yaml_text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(source + ":" + std::to_string(e.mark.line + 1) + ": invalid YAML: " + e.msg);
  }
  if (!root || root.IsNull()) throw ConfigError(source + ": the file is empty; expected a scenario mapping");
  return read(root, source);
}

Scenario load_scenario(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open the scenario file");
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_scenario(ss.str(), path);
}

}  // namespace tandem::sim
