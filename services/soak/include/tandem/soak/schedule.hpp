// The soak's fault schedule (the nemesis's plan): fault rules from a YAML file or a preset, and the schedule
// drawn from them with a seed. The same rules, seed and duration always give the same schedule; which process
// a fault hits is chosen when it fires, from the processes alive then, by the fault's drawn `pick`.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace tandem::soak {

enum class FaultKind { Kill, Stall, Unplug, Hog };
/// What a fault hits. robot: a robot serving an arm now; standby: a robot not serving; supervisor and
/// coordinator: the one serving (primary); world: a module's world (the whole module fails); module: a whole
/// module (unplug: drained and plugged in again).
enum class Target { Robot, Standby, Supervisor, Coordinator, World, Module, None };

const char* name(FaultKind k);
const char* name(Target t);
/// "kill robot", "stall world", "unplug module", "hog": the kind and target as one label.
std::string label(FaultKind k, Target t);

/// A rule of the schedule file: faults of one kind at a mean rate.
struct FaultRule {
  FaultKind kind = FaultKind::Kill;
  Target target = Target::Robot;
  double rate_per_min = 1.0;  ///< mean faults per minute (exponential gaps)
  int at_least = 1;           ///< drawn at least this often (if the duration has room)
  /// stall: how long the process is stopped; hog: how long it burns; kill world and unplug: how long until the
  /// module or robot is plugged in again. Drawn uniformly in [min_s, max_s].
  double min_s = 0.0, max_s = 0.0;
  int cores = 1;              ///< hog: busy processes (1 or 2 on this machine)
};

/// A fault at a fixed time, from the file's `at:` list (target: a process label such as m1/left, or a module).
struct FixedFault {
  double at_s = 0.0;
  FaultKind kind = FaultKind::Kill;
  Target target = Target::None;  ///< when no label is given: chosen as for a rule
  std::string label;             ///< explicit process label or module name ("" = choose)
  double duration_s = 0.0;
  int cores = 1;
  bool has_pick = false;
  uint64_t pick = 0;
};

struct FaultFile {
  std::string source;              ///< file path or "preset NAME"
  double warmup_s = 10.0;          ///< no fault before this
  double quiet_s = 10.0;           ///< no fault in the last quiet_s of the run (recoveries finish)
  double spacing_s = 1.0;          ///< at least this much between two faults
  std::vector<FaultRule> rules;
  std::vector<FixedFault> fixed;
};

/// One fault of the schedule.
struct Fault {
  int index = 0;                   ///< 1, 2, ... in time order
  double at_s = 0.0;
  FaultKind kind = FaultKind::Kill;
  Target target = Target::Robot;
  std::string label;               ///< fixed target ("" = choose from `pick`)
  double duration_s = 0.0;
  int cores = 1;
  uint64_t pick = 0;               ///< chooses among the candidates alive when it fires
};

struct Schedule {
  uint64_t seed = 0;
  double duration_s = 0.0;
  std::vector<Fault> faults;
};

class ScheduleError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Presets: mixed (every kind, about 17 faults a minute), ci (every kind at least once in a minute or two),
/// kills (robots only), none.
std::vector<std::string> preset_names();
FaultFile preset(const std::string& name);
/// Reads and validates a schedule file (strict: unknown keys and bad values are errors naming the key and
/// what is accepted). Throws ScheduleError.
FaultFile load_fault_file(const std::string& path);
FaultFile parse_fault_file(const std::string& yaml_text, const std::string& source);

/// Draws the schedule. Throws ScheduleError if the file's fixed faults lie outside [0, duration).
Schedule make_schedule(const FaultFile& file, uint64_t seed, double duration_s);

/// A small deterministic generator (splitmix64): the same seed gives the same numbers on every platform.
class Rng {
 public:
  explicit Rng(uint64_t seed) : s_(seed) {}
  uint64_t next();
  double uniform();  ///< [0, 1)
  double uniform(double a, double b) { return a + (b - a) * uniform(); }

 private:
  uint64_t s_;
};

/// The schedule as YAML (the report keeps it; it is also a valid `at:` list for a re-run).
std::string to_yaml(const Schedule& s);

}  // namespace tandem::soak
