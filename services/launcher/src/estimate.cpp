// The real-time capacity estimate and admission (estimate.hpp).
#include "tandem/launcher/estimate.hpp"

#include "tandem/launcher/cpu_plan.hpp"
#include "tandem/launcher/spin_watch.hpp"

#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <iterator>
#include <sstream>

#include "tandem/model/controller.hpp"
#include "tandem/model/plant.hpp"

namespace tandem::launcher {
namespace {

// Real-time cost figures when the calibration cannot run (bench/scale.sh, docs/benchmarks.md) and the share of the
// machine above which `tandem up` warns.
constexpr double kCorePerModule = 0.2;
constexpr double kCorePerStandbyRobot = 0.05;
constexpr double kUsableShare = 0.8;

}  // namespace

double process_cpu_s(int pid) {
  const std::string text = read_proc_text("/proc/" + std::to_string(pid) + "/stat");  // (no throw on a process gone)
  const size_t close = text.rfind(')');
  if (close == std::string::npos) return -1.0;
  std::istringstream in(text.substr(close + 2));
  std::string field;
  unsigned long long utime = 0, stime = 0;
  for (int i = 3; i <= 15 && in >> field; ++i) {  // fields 14 and 15: utime, stime (clock ticks)
    if (i == 14) utime = std::strtoull(field.c_str(), nullptr, 10);
    if (i == 15) stime = std::strtoull(field.c_str(), nullptr, 10);
  }
  return static_cast<double>(utime + stime) / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

void time_model(const sim::ModuleSetup& ms, Calibration& c) {
  auto thread_cpu_us = [] {
    timespec ts{};
    ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) * 1e6 + static_cast<double>(ts.tv_nsec) * 1e-3;
  };
  model::ModulePlant plant(ms.plant);
  plant.reset(ms.initial);
  const model::ArmEfforts tau{plant.arm(0).gravity(ms.initial.q[0]), plant.arm(1).gravity(ms.initial.q[1])};
  model::HybridController law(model::arm_model(ms.plant, 0), ms.control[0]);
  model::ArmSensors in;
  in.q = ms.initial.q[0];
  std::vector<double> plant_us, law_us;
  for (int batch = 0; batch < 5; ++batch) {
    double t = thread_cpu_us();
    for (int k = 0; k < 40; ++k) plant.step(tau, 0.0, ms.period, ms.substeps);
    plant_us.push_back((thread_cpu_us() - t) / 40.0);
    t = thread_cpu_us();
    for (int k = 0; k < 200; ++k) (void)law.step(in, sim::supervisor_reference(ms, 0, k));
    law_us.push_back((thread_cpu_us() - t) / 200.0);
  }
  std::sort(plant_us.begin(), plant_us.end());
  std::sort(law_us.begin(), law_us.end());
  c.plant_us = plant_us[2];
  c.law_us = law_us[2];
}

Capacity capacity_estimate(const LoadSpec& d) {
  Capacity cap;
  if (!d.realtime) {
    cap.text = "lockstep: no real-time load (it runs as fast as the machine allows)";
    return cap;
  }
  cap.realtime = true;
  const std::vector<int> cpus = d.pinned ? allowed_cpus() : std::vector<int>{};
  Calibration cal = calibrate_wakeup(300, cpus.empty() ? -1 : cpus.front());
  const auto t0 = std::chrono::steady_clock::now();
  if (!d.standbys.empty() && d.first_module) {
    try {
      if (const std::optional<sim::ModuleSetup> ms = d.first_module()) time_model(*ms, cal);
    } catch (const std::exception&) {
      // the scenario was checked when the file was loaded; a failure here only leaves the model's share out
    }
  }
  cal.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const CapacityModel model;
  const double per_module = cal.ok ? model.core_per_module(cal) : kCorePerModule;
  const double per_standby = cal.ok ? model.core_per_standby(cal) : kCorePerStandbyRobot;
  cap.per_module = per_module;
  cap.per_standby = per_standby;
  double need = 0.0;
  for (const int standby : d.standbys) need += per_module + 2.0 * standby * per_standby;
  const long cores = ::sysconf(_SC_NPROCESSORS_ONLN);
  cap.usable = kUsableShare * static_cast<double>(cores);
  const std::string measured = cal.ok ? "calibrated here: " + describe(cal)
                                      : std::string("the calibration could not run: figures from docs/benchmarks.md");
  char text[768];
  if (need > kUsableShare * static_cast<double>(cores)) {
    std::snprintf(text, sizeof text,
                  "warning: this deployment needs about %.2f cores in real time (%.3f per module, %.3f per standby "
                  "robot; %s) and this machine has %ld: expect modules to pause for load%s, or run it in lockstep",
                  need, per_module, per_standby, measured.c_str(), cores,
                  d.overload_brake ? " (the world holds the object and brakes; they resume when there is room)"
                                   : "; overload_brake is off, so late commands may drop objects");
  } else {
    std::snprintf(text, sizeof text, "real time: about %.2f of %ld cores (%.3f per module, %.3f per standby robot; %s)",
                  need, cores, per_module, per_standby, measured.c_str());
  }
  std::string out = text;
  if (d.simple_discovery && d.standbys.size() >= 4) {
    // Measured: 8 modules with simple discovery all paused for load at start-up, none with the server.
    out += "; with 4 or more modules 'discovery: server' keeps discovery from loading the machine";
  }
  cap.text = out;
  return cap;
}

Admission admission(const Capacity& cap, const std::vector<std::pair<std::string, int>>& modules, bool multi_host) {
  Admission a;
  double need = 0.0;
  bool full = false;
  for (const auto& [name, standby] : modules) {
    a.order.push_back(name);
    full = full || need + cap.of(standby) > cap.usable;
    if (!full) {
      need += cap.of(standby);
      ++a.fit;
    }
  }
  // With hosts: the estimate is of this machine, and the modules run on others too: admit them all (the governor
  // still parks modules whose worlds keep pausing for load). Seen: a three-host test's second module started
  // parked because all of them were counted against the launcher's machine.
  if (multi_host) a.fit = a.order.size();
  return a;
}

}  // namespace tandem::launcher
