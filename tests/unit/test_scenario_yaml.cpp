// The scenario loader: the shipped scenario parses to the paper's values, and every kind of bad input is
// rejected with a message naming the file, the key and what is accepted.
#include <catch2/catch.hpp>

#include <string>

#include "tandem/sim/scenario_yaml.hpp"

using tandem::sim::ConfigError;
using tandem::sim::parse_scenario;

namespace {

const std::string kPaper = std::string(TANDEM_SOURCE_DIR) + "/config/scenarios/paper.yaml";

// A minimal valid scenario; tests edit one line of it.
std::string minimal() {
  return R"(name: t
module:
  robots:
    - {name: a, selection_p: [1, 1, 1]}
    - {name: b}
  object: {mass: 2.0, mu_s: 0.5}
task:
  start: [-0.2, 0.8, 0.0]
  segments:
    - {to: [0.2, 0.8, 0.0], duration: 4.0}
controllers:
  pd: {law: pd}
cases:
  - {name: one, controller: pd}
)";
}

std::string replace(std::string s, const std::string& from, const std::string& to) {
  const auto pos = s.find(from);
  REQUIRE(pos != std::string::npos);
  return s.replace(pos, from.size(), to);
}

void require_error(const std::string& yaml, const std::vector<std::string>& fragments) {
  try {
    parse_scenario(yaml, "bad.yaml");
    FAIL("expected a ConfigError");
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    INFO(msg);
    CHECK(msg.rfind("bad.yaml", 0) == 0);  // names the file first
    for (const auto& f : fragments) CHECK(msg.find(f) != std::string::npos);
  }
}

}  // namespace

TEST_CASE("the shipped paper scenario loads with the paper's gains", "[config]") {
  const auto sc = tandem::sim::load_scenario(kPaper);
  CHECK(sc.name == "paper");
  CHECK(sc.period == Approx(1e-3));
  CHECK(sc.robots[1].selection_p == tandem::model::Vec3(1, 0, 1));  // eq. (17)
  const auto* pd = sc.find_controller("pd");
  REQUIRE(pd != nullptr);
  CHECK(pd->law.kp_p == tandem::model::Vec3(400, 450, 350));  // Table II
  CHECK(pd->law.kd_p == tandem::model::Vec3(35, 35, 35));
  CHECK(pd->law.kp_h == Approx(40));
  const auto* sm = sc.find_controller("sm");
  REQUIRE(sm != nullptr);
  CHECK(sm->law.K_p == tandem::model::Vec3(10, 10, 10));  // Table III
  CHECK(sm->law.K_h == Approx(1));
  CHECK(sm->law.m_p(0) == Approx(5));
  CHECK(sc.cases.size() >= 4);
}

TEST_CASE("a minimal scenario takes the documented defaults", "[config]") {
  const auto sc = parse_scenario(minimal(), "min.yaml");
  CHECK(sc.substeps == 10);
  CHECK(sc.duration == Approx(5.0));
  CHECK(sc.contact.k_normal == Approx(1e4));
  CHECK(sc.grasp_safety_factor == Approx(1.5));
  CHECK(sc.report_robot == 1);
  REQUIRE(sc.disturbed_robots.size() == 1);
  CHECK(sc.disturbed_robots[0] == 1);
}

TEST_CASE("bad scenarios name the file, the key and what is accepted", "[config]") {
  SECTION("unknown key") {
    require_error(replace(minimal(), "object: {mass: 2.0", "object: {colour: red, mass: 2.0"),
                  {"module.object.colour", "unknown key", "accepted keys here", "mass", "mu_s"});
  }
  SECTION("unknown top-level key, with its line") {
    require_error(minimal() + "speed: 3\n", {"bad.yaml:15", "'speed'", "unknown key"});
  }
  SECTION("wrong type") {
    require_error(replace(minimal(), "mass: 2.0", "mass: heavy"),
                  {"module.object.mass", "expected a number", "heavy"});
  }
  SECTION("missing required field") {
    require_error(replace(minimal(), "mass: 2.0, ", ""), {"module.object.mass", "missing required field"});
  }
  SECTION("negative mass") {
    require_error(replace(minimal(), "mass: 2.0", "mass: -2"), {"module.object.mass", "out of range", "-2"});
  }
  SECTION("list of the wrong length") {
    require_error(replace(minimal(), "start: [-0.2, 0.8, 0.0]", "start: [-0.2, 0.8]"),
                  {"task.start", "list of 3 numbers"});
  }
  SECTION("unknown law") {
    require_error(replace(minimal(), "law: pd", "law: fuzzy"),
                  {"controllers.pd.law", "sliding_mode", "super_twisting", "pd", "fuzzy"});
  }
  SECTION("case naming an undefined controller") {
    require_error(replace(minimal(), "controller: pd}", "controller: lqr}"),
                  {"cases[0].controller", "unknown controller 'lqr'", "defined: pd"});
  }
  SECTION("selection must be the hybrid or the position-only one") {
    require_error(replace(minimal(), "selection_p: [1, 1, 1]", "selection_p: [1, 0.5, 1]"),
                  {"selection_p", "[1, 0, 1]", "[1, 1, 1]"});
    require_error(replace(minimal(), "selection_p: [1, 1, 1]", "selection_p: [0, 1, 0]"),
                  {"selection_p", "[1, 0, 1]"});
  }
  SECTION("elbow is -1 or 1") {
    require_error(replace(minimal(), "{name: b}", "{name: b, elbow: 0.3}"), {"robots[1].elbow", "-1 or 1"});
  }
  SECTION("a key given twice") {
    require_error(replace(minimal(), "  start: [-0.2, 0.8, 0.0]\n", "  start: [-0.2, 0.8, 0.0]\n  start: [0, 0.8, 0]\n"),
                  {"task.start", "given twice"});
  }
  SECTION("case names that map to the same file") {
    require_error(minimal() + "  - {name: x y, controller: pd}\n  - {name: x_y, controller: pd}\n",
                  {"cases[2].name", "clashes with 'x y'"});
  }
  SECTION("a name that would leave the output directory") {
    require_error(replace(minimal(), "name: t", "name: ../../x"), {"'name'", "output directory"});
  }
  SECTION("a module has two robots") {
    require_error(replace(minimal(), "    - {name: b}\n", ""), {"module.robots", "exactly 2 robots"});
  }
  SECTION("mu_k above mu_s") {
    require_error(replace(minimal(), "mu_s: 0.5", "mu_s: 0.5, mu_k: 0.9"), {"mu_k", "must not exceed mu_s"});
  }
  SECTION("disturbed robot that does not exist") {
    require_error(minimal() + "disturbed_robots: [c]\n", {"disturbed_robots[0]", "unknown robot 'c'", "a, b"});
  }
  SECTION("not YAML at all") {
    require_error("name: [unclosed\n", {"invalid YAML"});
  }
  SECTION("NaN is not a number we accept") {
    require_error(replace(minimal(), "mass: 2.0", "mass: .nan"), {"module.object.mass", "out of range"});
  }
}

TEST_CASE("a missing scenario file is reported with its path", "[config]") {
  try {
    tandem::sim::load_scenario("/nonexistent/x.yaml");
    FAIL("expected a ConfigError");
  } catch (const ConfigError& e) {
    CHECK(std::string(e.what()).find("/nonexistent/x.yaml: cannot open") != std::string::npos);
  }
}
