#include "tandem/soak/schedule.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace tandem::soak {
namespace {

[[noreturn]] void fail(const std::string& source, const std::string& what) {
  throw ScheduleError(source + ": " + what);
}

std::string where(const YAML::Node& n) {
  return "line " + std::to_string(n.Mark().line + 1);
}

void only_keys(const YAML::Node& map, const std::set<std::string>& allowed, const std::string& source,
               const std::string& context) {
  for (const auto& kv : map) {
    const std::string k = kv.first.as<std::string>();
    if (allowed.count(k) == 0) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      fail(source, context + " (" + where(kv.first) + "): unknown key '" + k + "' (accepted: " + list + ")");
    }
  }
}

double number(const YAML::Node& n, const std::string& key, double lo, double hi, const std::string& source,
              const std::string& context) {
  double v = 0.0;
  try {
    v = n.as<double>();
  } catch (const YAML::Exception&) {
    fail(source, context + " (" + where(n) + "): '" + key + "' must be a number, got '" + n.Scalar() + "'");
  }
  if (!std::isfinite(v) || v < lo || v > hi) {
    std::ostringstream o;
    o << context << " (" << where(n) << "): '" << key << "' = " << n.Scalar() << " is out of range (accepted: " << lo
      << " to " << hi << ")";
    fail(source, o.str());
  }
  return v;
}

FaultKind parse_kind(const YAML::Node& n, const std::string& source, const std::string& context) {
  const std::string s = n.as<std::string>("");
  if (s == "kill") return FaultKind::Kill;
  if (s == "stall") return FaultKind::Stall;
  if (s == "unplug") return FaultKind::Unplug;
  if (s == "hog") return FaultKind::Hog;
  fail(source, context + " (" + where(n) + "): 'kind' = '" + s + "' is not a fault kind (accepted: kill, stall, unplug, hog)");
}

Target parse_target(const YAML::Node& n, FaultKind kind, const std::string& source, const std::string& context) {
  const std::string s = n.as<std::string>("");
  static const std::vector<std::pair<std::string, Target>> all{
      {"robot", Target::Robot},           {"standby", Target::Standby}, {"supervisor", Target::Supervisor},
      {"coordinator", Target::Coordinator}, {"world", Target::World},   {"module", Target::Module}};
  std::vector<std::string> accepted;
  if (kind == FaultKind::Kill || kind == FaultKind::Stall) {
    accepted = {"robot", "standby", "supervisor", "coordinator", "world"};
  } else if (kind == FaultKind::Unplug) {
    accepted = {"robot", "standby", "module"};
  }
  for (const auto& a : accepted) {
    if (a == s) {
      for (const auto& [k, t] : all) {
        if (k == s) return t;
      }
    }
  }
  std::string list;
  for (const auto& a : accepted) list += (list.empty() ? "" : ", ") + a;
  fail(source, context + " (" + where(n) + "): 'target' = '" + s + "' is not accepted for " + name(kind) +
                   " (accepted: " + list + ")");
}

/// Default duration range of a fault: stall length, hog length, time until plugged in again.
void default_range(FaultKind kind, Target target, double& lo, double& hi) {
  switch (kind) {
    case FaultKind::Stall: lo = 0.01; hi = 2.0; return;
    case FaultKind::Hog: lo = 2.0; hi = 8.0; return;
    case FaultKind::Unplug: lo = 1.0; hi = 5.0; return;
    case FaultKind::Kill:
      if (target == Target::World) {
        lo = 2.0;
        hi = 5.0;
      } else {
        lo = hi = 0.0;
      }
      return;
  }
}

FaultFile parse(const YAML::Node& root, const std::string& source) {
  if (!root.IsMap()) fail(source, "expected a map with 'faults' and/or 'at' (see docs/soak.md)");
  only_keys(root, {"warmup", "quiet", "spacing", "faults", "at"}, source, "top level");
  FaultFile f;
  f.source = source;
  if (root["warmup"]) f.warmup_s = number(root["warmup"], "warmup", 0.0, 86400.0, source, "top level");
  if (root["quiet"]) f.quiet_s = number(root["quiet"], "quiet", 0.0, 86400.0, source, "top level");
  if (root["spacing"]) f.spacing_s = number(root["spacing"], "spacing", 0.0, 3600.0, source, "top level");
  if (root["faults"]) {
    if (!root["faults"].IsSequence()) fail(source, "'faults' must be a list of rules ({kind: ..., target: ..., rate: ...})");
    int i = 0;
    for (const auto& r : root["faults"]) {
      const std::string ctx = "faults[" + std::to_string(i++) + "]";
      if (!r.IsMap()) fail(source, ctx + " (" + where(r) + "): expected a map {kind, target, rate, ...}");
      only_keys(r, {"kind", "target", "rate", "at_least", "min", "max", "cores"}, source, ctx);
      if (!r["kind"]) fail(source, ctx + " (" + where(r) + "): missing 'kind' (accepted: kill, stall, unplug, hog)");
      FaultRule rule;
      rule.kind = parse_kind(r["kind"], source, ctx);
      if (rule.kind == FaultKind::Hog) {
        rule.target = Target::None;
        if (r["target"]) fail(source, ctx + ": 'target' is not accepted for hog (it loads the machine's cores)");
      } else {
        if (!r["target"]) fail(source, ctx + " (" + where(r) + "): missing 'target'");
        rule.target = parse_target(r["target"], rule.kind, source, ctx);
      }
      if (!r["rate"]) fail(source, ctx + " (" + where(r) + "): missing 'rate' (faults per minute)");
      rule.rate_per_min = number(r["rate"], "rate", 0.0, 600.0, source, ctx);
      if (r["at_least"]) rule.at_least = static_cast<int>(number(r["at_least"], "at_least", 0, 100000, source, ctx));
      default_range(rule.kind, rule.target, rule.min_s, rule.max_s);
      if (r["min"]) rule.min_s = number(r["min"], "min", 0.0, 3600.0, source, ctx);
      if (r["max"]) rule.max_s = number(r["max"], "max", 0.0, 3600.0, source, ctx);
      if (rule.max_s < rule.min_s) fail(source, ctx + ": 'max' is below 'min'");
      if (rule.kind == FaultKind::Stall && rule.min_s < 0.001) fail(source, ctx + ": a stall lasts at least 'min: 0.001' s");
      if (r["cores"]) {
        if (rule.kind != FaultKind::Hog) fail(source, ctx + ": 'cores' is only for hog");
        rule.cores = static_cast<int>(number(r["cores"], "cores", 1, 64, source, ctx));
      }
      f.rules.push_back(rule);
    }
  }
  if (root["at"]) {
    if (!root["at"].IsSequence()) fail(source, "'at' must be a list of faults ({at: SECONDS, kind: ..., process: ...})");
    int i = 0;
    for (const auto& r : root["at"]) {
      const std::string ctx = "at[" + std::to_string(i++) + "]";
      if (!r.IsMap()) fail(source, ctx + " (" + where(r) + "): expected a map {at, kind, target or process, ...}");
      only_keys(r, {"at", "kind", "target", "process", "duration", "cores", "pick"}, source, ctx);
      if (!r["at"]) fail(source, ctx + ": missing 'at' (seconds from the start)");
      if (!r["kind"]) fail(source, ctx + ": missing 'kind' (accepted: kill, stall, unplug, hog)");
      FixedFault ff;
      ff.at_s = number(r["at"], "at", 0.0, 1e7, source, ctx);
      ff.kind = parse_kind(r["kind"], source, ctx);
      if (r["target"]) {
        if (ff.kind == FaultKind::Hog) fail(source, ctx + ": 'target' is not accepted for hog");
        ff.target = parse_target(r["target"], ff.kind, source, ctx);
      }
      if (r["process"]) {
        if (ff.kind == FaultKind::Hog) fail(source, ctx + ": 'process' is not accepted for hog");
        ff.label = r["process"].as<std::string>("");
        if (ff.label.empty()) fail(source, ctx + ": 'process' must name a process (m1/left, m1/world, coordinator) or a module");
      }
      if (ff.kind != FaultKind::Hog && ff.target == Target::None && ff.label.empty()) {
        fail(source, ctx + ": give 'target' (a role) or 'process' (a label)");
      }
      double lo = 0, hi = 0;
      default_range(ff.kind, ff.target, lo, hi);
      if (ff.kind == FaultKind::Kill && ff.target == Target::None && ff.label.find('/') == std::string::npos) {
        lo = hi = 0.0;
      }
      ff.duration_s = 0.5 * (lo + hi);
      if (r["duration"]) ff.duration_s = number(r["duration"], "duration", 0.0, 3600.0, source, ctx);
      if (r["cores"]) {
        if (ff.kind != FaultKind::Hog) fail(source, ctx + ": 'cores' is only for hog");
        ff.cores = static_cast<int>(number(r["cores"], "cores", 1, 64, source, ctx));
      }
      if (r["pick"]) {
        try {
          ff.pick = r["pick"].as<uint64_t>();
        } catch (const YAML::Exception&) {
          fail(source, ctx + ": 'pick' must be a whole number >= 0");
        }
        ff.has_pick = true;
      }
      f.fixed.push_back(ff);
    }
  }
  if (f.rules.empty() && f.fixed.empty() && !root["faults"] && !root["at"]) {
    fail(source, "no 'faults' and no 'at': nothing to inject (an empty list is accepted for a soak without faults)");
  }
  return f;
}

FaultRule rule(FaultKind k, Target t, double rate, double lo = -1, double hi = -1, int cores = 1) {
  FaultRule r;
  r.kind = k;
  r.target = t;
  r.rate_per_min = rate;
  default_range(k, t, r.min_s, r.max_s);
  if (lo >= 0) r.min_s = lo;
  if (hi >= 0) r.max_s = hi;
  r.cores = cores;
  return r;
}

}  // namespace

const char* name(FaultKind k) {
  switch (k) {
    case FaultKind::Kill: return "kill";
    case FaultKind::Stall: return "stall";
    case FaultKind::Unplug: return "unplug";
    case FaultKind::Hog: return "hog";
  }
  return "?";
}

const char* name(Target t) {
  switch (t) {
    case Target::Robot: return "robot";
    case Target::Standby: return "standby";
    case Target::Supervisor: return "supervisor";
    case Target::Coordinator: return "coordinator";
    case Target::World: return "world";
    case Target::Module: return "module";
    case Target::None: return "";
  }
  return "?";
}

std::string label(FaultKind k, Target t) {
  return t == Target::None ? std::string(name(k)) : std::string(name(k)) + " " + name(t);
}

uint64_t Rng::next() {
  uint64_t z = (s_ += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

double Rng::uniform() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }

std::vector<std::string> preset_names() { return {"mixed", "ci", "kills", "none"}; }

FaultFile preset(const std::string& name_) {
  FaultFile f;
  f.source = "preset " + name_;
  using K = FaultKind;
  using T = Target;
  if (name_ == "mixed") {
    // About 20 faults a minute (1200 in an hour), every kind; robots hit most, as they are most numerous.
    f.warmup_s = 10.0;
    f.quiet_s = 15.0;
    f.spacing_s = 1.0;
    f.rules = {rule(K::Kill, T::Robot, 6.0),        rule(K::Kill, T::Standby, 2.5),
               rule(K::Kill, T::Supervisor, 1.0),   rule(K::Kill, T::Coordinator, 0.5),
               rule(K::Kill, T::World, 0.5),        rule(K::Stall, T::Robot, 3.0),
               rule(K::Stall, T::Standby, 0.5),     rule(K::Stall, T::Supervisor, 1.5),
               rule(K::Stall, T::Coordinator, 0.5), rule(K::Stall, T::World, 0.5, 0.01, 0.5),
               rule(K::Unplug, T::Robot, 1.0),      rule(K::Unplug, T::Standby, 1.0),
               rule(K::Unplug, T::Module, 0.5, 2.0, 6.0), rule(K::Hog, T::None, 1.0, 2.0, 8.0, 1),
               rule(K::Hog, T::None, 0.5, 1.0, 4.0, 2)};
  } else if (name_ == "ci") {
    // Every kind at least once in a short run: low rates, one of each guaranteed.
    f.warmup_s = 6.0;
    f.quiet_s = 10.0;
    f.spacing_s = 2.0;
    f.rules = {rule(K::Kill, T::Robot, 1.0),        rule(K::Kill, T::Standby, 0.5),
               rule(K::Kill, T::Supervisor, 0.3),   rule(K::Kill, T::Coordinator, 0.3),
               rule(K::Kill, T::World, 0.3, 2.0, 3.0), rule(K::Stall, T::Robot, 0.5, 0.01, 1.0),
               rule(K::Stall, T::Supervisor, 0.3, 0.01, 1.0), rule(K::Stall, T::World, 0.3, 0.01, 0.3),
               rule(K::Unplug, T::Robot, 0.3, 1.0, 2.0), rule(K::Unplug, T::Module, 0.3, 1.0, 2.0),
               rule(K::Hog, T::None, 0.3, 2.0, 3.0, 1), rule(K::Hog, T::None, 0.3, 1.0, 2.0, 2)};
  } else if (name_ == "kills") {
    f.rules = {rule(K::Kill, T::Robot, 6.0), rule(K::Kill, T::Standby, 3.0)};
  } else if (name_ == "none") {
  } else {
    std::string list;
    for (const auto& n : preset_names()) list += (list.empty() ? "" : ", ") + n;
    throw ScheduleError("--faults '" + name_ + "': no such file and not a preset (presets: " + list + ")");
  }
  return f;
}

FaultFile load_fault_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ScheduleError(path + ": cannot read the schedule file");
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_fault_file(ss.str(), path);
}

FaultFile parse_fault_file(const std::string& yaml_text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw ScheduleError(source + ": not valid YAML: " + e.what());
  }
  try {
    return parse(root, source);
  } catch (const YAML::Exception& e) {
    throw ScheduleError(source + ": " + e.what());
  }
}

Schedule make_schedule(const FaultFile& file, uint64_t seed, double duration_s) {
  Schedule s;
  s.seed = seed;
  s.duration_s = duration_s;
  const double begin = file.warmup_s, end = duration_s - file.quiet_s;
  Rng rng(seed);
  std::vector<Fault> drawn;
  if (end > begin) {
    for (const FaultRule& r : file.rules) {
      // Each rule has its own stream (so adding a rule does not move the others' faults).
      Rng rr(rng.next());
      std::vector<double> times;
      if (r.rate_per_min > 0.0) {
        const double mean_gap = 60.0 / r.rate_per_min;
        for (double t = begin - mean_gap * std::log(1.0 - rr.uniform()); t < end;
             t += -mean_gap * std::log(1.0 - rr.uniform())) {
          times.push_back(t);
        }
      }
      while (static_cast<int>(times.size()) < r.at_least) times.push_back(rr.uniform(begin, end));
      for (double t : times) {
        Fault f;
        f.at_s = t;
        f.kind = r.kind;
        f.target = r.target;
        f.duration_s = rr.uniform(r.min_s, r.max_s);
        f.cores = r.cores;
        f.pick = rr.next();
        drawn.push_back(f);
      }
    }
  }
  std::sort(drawn.begin(), drawn.end(), [](const Fault& a, const Fault& b) { return a.at_s < b.at_s; });
  // Spacing: faults closer than spacing_s move apart (later ones later, then back from the end if that pushed
  // any past it); when they do not fit at that spacing, the spacing shrinks. None is dropped.
  std::vector<Fault> spaced = drawn;
  if (!spaced.empty()) {
    const double sp = std::min(file.spacing_s, (end - begin) / static_cast<double>(spaced.size()));
    for (size_t i = 1; i < spaced.size(); ++i) spaced[i].at_s = std::max(spaced[i].at_s, spaced[i - 1].at_s + sp);
    spaced.back().at_s = std::min(spaced.back().at_s, end - 1e-3);
    for (size_t i = spaced.size() - 1; i-- > 0;) spaced[i].at_s = std::min(spaced[i].at_s, spaced[i + 1].at_s - sp);
  }
  for (const FixedFault& ff : file.fixed) {
    if (ff.at_s >= duration_s) {
      std::ostringstream o;
      o << file.source << ": a fault at " << ff.at_s << " s is past the end of the run (" << duration_s << " s)";
      throw ScheduleError(o.str());
    }
    Fault f;
    f.at_s = ff.at_s;
    f.kind = ff.kind;
    f.target = ff.target;
    f.label = ff.label;
    f.duration_s = ff.duration_s;
    f.cores = ff.cores;
    const uint64_t drawn_pick = rng.next();
    f.pick = ff.has_pick ? ff.pick : drawn_pick;
    spaced.push_back(f);
  }
  std::stable_sort(spaced.begin(), spaced.end(), [](const Fault& a, const Fault& b) { return a.at_s < b.at_s; });
  for (size_t i = 0; i < spaced.size(); ++i) spaced[i].index = static_cast<int>(i + 1);
  s.faults = std::move(spaced);
  return s;
}

std::string to_yaml(const Schedule& s) {
  std::ostringstream o;
  o.precision(6);
  o << "# tandem soak schedule: seed " << s.seed << ", " << s.duration_s << " s, " << s.faults.size() << " fault(s)\n";
  o << "warmup: 0\nquiet: 0\nspacing: 0\nat:\n";
  for (const Fault& f : s.faults) {
    o << "  - {at: " << std::fixed << f.at_s << std::defaultfloat << ", kind: " << name(f.kind);
    if (!f.label.empty()) o << ", process: " << f.label;
    if (f.target != Target::None) o << ", target: " << name(f.target);
    if (f.kind != FaultKind::Kill || f.target == Target::World) o << ", duration: " << f.duration_s;
    if (f.kind == FaultKind::Hog) o << ", cores: " << f.cores;
    o << ", pick: " << f.pick << "}\n";
  }
  return o.str();
}

}  // namespace tandem::soak
