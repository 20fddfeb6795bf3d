// The role processes' and the coordinator's command lines (runtime::parse_role_options, coordinator::parse_options,
// on CLI11): what they accept, and that every bad value is refused by name with what is accepted.
#include <catch2/catch.hpp>

#include <string>
#include <vector>

#include "tandem/coordinator/options.hpp"
#include "tandem/runtime/args.hpp"
#include "tandem/runtime/role.hpp"

namespace {

struct Parsed {
  bool ok = false;
  int code = -1;
  std::string err;
  tandem::runtime::RoleOptions o;
};

Parsed role(const char* name, bool needs_arm, std::vector<const char*> args) {
  args.insert(args.begin(), "tandem-x");
  Parsed p;
  p.ok = tandem::runtime::parse_role_options(name, static_cast<int>(args.size()), args.data(), needs_arm, p.o, p.code,
                                             &p.err);
  return p;
}

}  // namespace

TEST_CASE("role options: every flag the launcher passes is read into the options", "[args]") {
  const Parsed p = role("robot", true, {"--scenario", "s.yaml", "--case", "SOSM", "--module", "m3", "--arm", "left",
                                        "--domain", "41", "--transport", "udp", "--timeout", "2.5", "--timing", "realtime",
                                        "--deployment", "soak", "--continuous", "--strength", "49"});
  REQUIRE(p.ok);
  CHECK(p.code == 0);
  CHECK(p.o.scenario == "s.yaml");
  CHECK(p.o.case_name == "SOSM");
  CHECK(p.o.module == "m3");
  CHECK(p.o.arm == "left");
  CHECK(p.o.domain == 41);
  CHECK(p.o.transport == tandem::dds::Transport::Udp);
  CHECK(p.o.timeout == 2.5);
  CHECK(p.o.realtime);
  CHECK(p.o.deployment == "soak");
  CHECK(p.o.continuous);
  CHECK(p.o.strength == 49);
  CHECK(p.o.overload_brake);
  // The defaults: lockstep over shared memory, domain 0, module m1, primary strength.
  const Parsed d = role("world", false, {"--scenario", "s.yaml", "--case", "PD", "--no-overload-brake", "--observers", "3"});
  REQUIRE(d.ok);
  CHECK_FALSE(d.o.realtime);
  CHECK(d.o.transport == tandem::dds::Transport::SharedMemory);
  CHECK(d.o.domain == 0);
  CHECK(d.o.module == "m1");
  CHECK(d.o.strength == 100);
  CHECK_FALSE(d.o.overload_brake);
  CHECK(d.o.observers == 3);
}

TEST_CASE("role options: bad values are refused by name, with exit code 2, and --help exits 0", "[args]") {
  struct Bad {
    const char* role;
    bool arm;
    std::vector<const char*> args;
    const char* says;
  };
  const std::vector<Bad> bad = {
      {"world", false, {"--case", "PD"}, "--scenario"},
      {"robot", true, {"--scenario", "s", "--case", "PD"}, "--arm"},
      {"world", false, {"--scenario", "s", "--case", "PD", "--domain", "233"}, "--domain"},
      {"world", false, {"--scenario", "s", "--case", "PD", "--domain", "7x"}, "--domain"},
      {"world", false, {"--scenario", "s", "--case", "PD", "--transport", "tcp"}, "--transport"},
      {"world", false, {"--scenario", "s", "--case", "PD", "--timing", "fast"}, "--timing"},
      {"world", false, {"--scenario", "s", "--case", "PD", "--timeout", "0"}, "--timeout"},
      {"world", false, {"--scenario", "s", "--case", "PD", "--timeout", "nan"}, "--timeout"},
      {"world", false, {"--scenario", "s", "--case", "PD", "--observers", "17"}, "--observers"},
      {"world", false, {"--scenario", "s", "--case", "PD", "--standbys", "8"}, "--standbys"},
      {"world", false, {"--scenario", "s", "--case", "PD", "--strength", "50"}, "--strength"},  // robots and supervisors only
      {"robot", true, {"--scenario", "s", "--case", "PD", "--arm", "left", "--strength", "0"}, "--strength"},
      {"supervisor", false, {"--scenario", "s", "--case", "PD", "--speed", "2"}, "--speed"},
  };
  for (const Bad& b : bad) {
    const Parsed p = role(b.role, b.arm, b.args);
    INFO(b.role << ": " << p.err);
    CHECK_FALSE(p.ok);
    CHECK(p.code == 2);
    CHECK(p.err.find(b.says) != std::string::npos);
    CHECK(p.err.find(std::string("tandem-") + b.role + ": ") == 0);
  }
  const Parsed h = role("world", false, {"--help"});
  CHECK_FALSE(h.ok);
  CHECK(h.code == 0);
}

TEST_CASE("coordinator options: read, defaults, and bad values refused by name", "[args]") {
  using tandem::coordinator::Options;
  auto parse = [](std::vector<const char*> args, Options& o, std::string& err) {
    args.insert(args.begin(), "tandem-coordinator");
    return tandem::coordinator::parse_options(static_cast<int>(args.size()), args.data(), o, &err);
  };
  Options o;
  std::string err;
  CHECK(parse({"--deployment-file", "d.yaml", "--domain", "12", "--standby", "--resume", "--id", "coordinator@r3",
               "--timeout", "45"}, o, err) == -1);
  CHECK(o.file == "d.yaml");
  CHECK(o.domain == 12);
  CHECK(o.standby);
  CHECK(o.resume);
  CHECK(o.id == "coordinator@r3");
  CHECK(o.timeout == 45.0);
  Options d;
  CHECK(parse({"--deployment-file", "d.yaml", "--domain", "0"}, d, err) == -1);
  CHECK(d.id == "coordinator");
  CHECK(d.timeout == 30.0);
  CHECK_FALSE(d.standby);
  const std::vector<std::pair<std::vector<const char*>, const char*>> bad = {
      {{"--domain", "1"}, "--deployment-file"},
      {{"--deployment-file", "d.yaml"}, "--domain"},
      {{"--deployment-file", "d.yaml", "--domain", "-1"}, "--domain"},
      {{"--deployment-file", "d.yaml", "--domain", "1", "--timeout", "0"}, "--timeout"},
      {{"--deployment-file", "d.yaml", "--domain", "1", "--timeout", "90000"}, "--timeout"},
      {{"--deployment-file", "d.yaml", "--domain", "1", "--id", ""}, "--id"},
      {{"--deployment-file", "d.yaml", "--domain", "1", "--queue", "x"}, "--queue"},
  };
  for (const auto& [args, says] : bad) {
    Options b;
    err.clear();
    INFO(err);
    CHECK(parse(args, b, err) == 2);
    CHECK(err.find(says) != std::string::npos);
  }
}

TEST_CASE("one form: the launcher's command line of a role reads back as the same options, for every role and value", "[args]") {
  using tandem::runtime::RoleOptions;
  for (const std::string r : {"world", "robot", "supervisor"}) {
    for (int variant = 0; variant < 2; ++variant) {
      RoleOptions o;
      o.scenario = "/some where/paper.yaml";
      o.case_name = variant == 0 ? "SOSM" : "PD";
      o.module = "m7";
      o.arm = r == "robot" ? "right" : "";
      o.domain = variant == 0 ? 0 : 232;
      o.transport = variant == 0 ? tandem::dds::Transport::Udp : tandem::dds::Transport::SharedMemory;
      o.timeout = variant == 0 ? 0.1 + 0.2 : 20.0;  // not exact in decimal: read back bit for bit
      o.realtime = variant == 0;
      o.deployment = variant == 0 ? "soak-four" : "";
      o.continuous = variant == 0;
      o.overload_brake = variant != 0;
      o.test_no_brakes = variant == 0;
      o.observers = variant == 0 ? 3 : 0;
      o.standbys = variant == 0 ? 2 : 0;
      o.strength = r == "world" ? RoleOptions::kPrimaryStrength : (variant == 0 ? 49 : 100);
      const std::vector<std::string> args = tandem::runtime::role_args(r, o);
      std::vector<const char*> argv{"tandem-x"};
      for (const std::string& a : args) argv.push_back(a.c_str());
      RoleOptions back;
      int code = -1;
      std::string err;
      INFO(r << " variant " << variant << ": " << err);
      REQUIRE(tandem::runtime::parse_role_options(r.c_str(), static_cast<int>(argv.size()), argv.data(), r == "robot",
                                                  back, code, &err));
      CHECK(back.scenario == o.scenario);
      CHECK(back.case_name == o.case_name);
      CHECK(back.module == o.module);
      CHECK(back.arm == o.arm);
      CHECK(back.domain == o.domain);
      CHECK(back.transport == o.transport);
      CHECK(back.timeout == o.timeout);
      CHECK(back.realtime == o.realtime);
      CHECK(back.deployment == o.deployment);
      CHECK(back.continuous == o.continuous);
      CHECK(back.overload_brake == o.overload_brake);
      CHECK(back.test_no_brakes == o.test_no_brakes);
      CHECK(back.observers == o.observers);
      CHECK(back.standbys == o.standbys);
      CHECK(back.strength == o.strength);
    }
  }
  tandem::coordinator::Options c;
  c.file = "/tmp/d.yaml";
  c.domain = 9;
  c.timeout = 0.1 + 0.2;
  c.id = "coordinator@r12";
  c.standby = true;
  c.resume = true;
  const std::vector<std::string> args = tandem::coordinator::to_args(c);
  std::vector<const char*> argv{"tandem-coordinator"};
  for (const std::string& a : args) argv.push_back(a.c_str());
  tandem::coordinator::Options back;
  REQUIRE(tandem::coordinator::parse_options(static_cast<int>(argv.size()), argv.data(), back) == -1);
  CHECK(back.file == c.file);
  CHECK(back.domain == c.domain);
  CHECK(back.timeout == c.timeout);
  CHECK(back.id == c.id);
  CHECK(back.standby);
  CHECK(back.resume);
}

TEST_CASE("subcommand arguments: checks for choices, durations and whole numbers, and a stray option said first", "[args]") {
  namespace rt = tandem::runtime;
  CHECK(rt::parse_duration("90") == 90.0);
  CHECK(rt::parse_duration("90s") == 90.0);
  CHECK(rt::parse_duration("1.5m") == 90.0);
  CHECK(rt::parse_duration("1h") == 3600.0);
  for (const char* bad : {"", "0", "-5", "10x", "h", "nan", "1e999"}) {
    INFO(bad);
    CHECK(rt::parse_duration(bad) < 0.0);
  }
  std::string timing = "realtime", duration = "10m", seed = "1", out, file;
  CLI::App app("", "tandem test");
  app.add_option("file", file)->required();
  app.add_option("--timing", timing)->check(rt::one_of({"realtime", "lockstep"}));
  app.add_option("--duration", duration)->check(rt::duration());
  app.add_option("--seed", seed)->check(rt::whole_number());
  app.add_option("-o,--out", out)->required();
  auto run = [&app](const std::vector<std::string>& args, std::string& err) { return rt::parse_args(app, args, &err); };
  std::string err;
  CHECK(run({"f.yaml", "--timing", "lockstep", "--duration", "2m", "--seed", "42", "-o", "x"}, err) == -1);
  CHECK(timing == "lockstep");
  CHECK(seed == "42");
  CHECK(file == "f.yaml");
  const std::vector<std::pair<std::vector<std::string>, std::string>> bad{
      {{"f.yaml", "-o", "x", "--timing", "fast"}, "--timing: 'fast' is not accepted; accepted: realtime, lockstep"},
      {{"f.yaml", "-o", "x", "--duration", "0"}, "--duration: '0': expected a time above 0"},
      {{"f.yaml", "-o", "x", "--seed", "1.5"}, "--seed: '1.5': expected a whole number >= 0"},
      {{"f.yaml", "-o", "x", "--seed", "-3"}, "expected a whole number >= 0"},
      {{"f.yaml"}, "--out is required"},
      // a misspelt required option: the stray word is said, not the missing option
      {{"f.yaml", "--uot", "x"}, "unknown option or extra argument '--uot'"},
  };
  for (const auto& [args, want] : bad) {
    INFO(want);
    CLI::App again("", "tandem test");
    std::string f2, t2 = "realtime", d2 = "1", s2 = "1", o2;
    again.add_option("file", f2)->required();
    again.add_option("--timing", t2)->check(rt::one_of({"realtime", "lockstep"}));
    again.add_option("--duration", d2)->check(rt::duration());
    again.add_option("--seed", s2)->check(rt::whole_number());
    again.add_option("-o,--out", o2)->required();
    std::string e;
    CHECK(rt::parse_args(again, args, &e) == 2);
    CHECK(e.rfind("tandem test: ", 0) == 0);
    CHECK(e.find(want) != std::string::npos);
  }
}

TEST_CASE("integer options are decimal: CLI11 alone would read 010 as 8", "[args]") {
  int domain = -1;
  CLI::App app("", "tandem test");
  tandem::runtime::add_domain(app, domain);
  std::string err;
  CHECK(tandem::runtime::parse_args(app, std::vector<std::string>{"--domain", "010"}, &err) == 2);
  CHECK(err.find("'010' is not a whole number in decimal") != std::string::npos);
  CLI::App ok("", "tandem test");
  tandem::runtime::add_domain(ok, domain);
  CHECK(tandem::runtime::parse_args(ok, std::vector<std::string>{"--domain", "10"}, &err) == -1);
  CHECK(domain == 10);
}
