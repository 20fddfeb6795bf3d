// Real-time capacity measured on the machine at hand (docs/benchmarks.md, "Capacity"). What a module costs in
// real time is mostly cross-process wake-ups (a world on a 1 kHz timer, a robot woken by each sample, the world
// woken by each command), and a wake-up costs what the host makes it cost: hosts differed by 1.7x. So the
// estimate is calibrated here, in well under a second, from
//   - the CPU of one cross-process wake-up: two processes ping-pong through futexes in shared memory once per
//     1 ms tick, the way the wake-up floor does (shared/tools/wakefloor.c), and the CPU both used is divided by
//     the wake-ups;
//   - the CPU of one plant step and one control-law step (passed in: measured by the caller on the model);
// and a per-module model: W wake-ups per tick, each paid `dds_factor` times over by the middleware (the fitted
// ratio of the runtime to its floor, measured by bench/scale.sh beside the floor in the same run).
#pragma once

#include <string>

namespace tandem::launcher {

struct Calibration {
  double wake_us = 0.0;   ///< CPU per cross-process wake-up, both sides [us]
  double plant_us = 0.0;  ///< one plant step of one module (its RK4 substeps) [us]
  double law_us = 0.0;    ///< one control-law step of one robot [us]
  double seconds = 0.0;   ///< wall time the calibration took
  bool ok = false;        ///< the wake-up measurement ran (fork and shared memory worked)
};

/// Measures the CPU of a cross-process wake-up: `ticks` ticks of 1 ms, each a futex round trip between this
/// process (woken by its timer) and a forked child, so that the cores idle between ticks as in a deployment;
/// the CPU both used over 3 wake-ups per tick. Fills wake_us, seconds and ok. With `cpu` >= 0 both run on that
/// CPU (the calling thread's affinity is put back after), as a module's processes do with `cpu_affinity: module`:
/// a wake-up across CPUs of a virtual machine costs several times one on the same CPU.
Calibration calibrate_wakeup(int ticks = 300, int cpu = -1);

/// The per-module cost model (docs/benchmarks.md, "Capacity").
struct CapacityModel {
  /// Wake-ups per tick of a basic module: the world's timer, a robot's listener per sample (2), the world's
  /// listener per command (2).
  static constexpr double kWakesPerTick = 5.0;
  /// A standby robot: its listener per sample, and the world's reader taking its command (which exclusive
  /// ownership then drops). Measured, not counted: a standby robot costs 1.1 wake-ups' worth a tick (2026-11-28,
  /// `STANDBY=1 bash bench/scale.sh 1 2` beside `bash bench/scale.sh 1 2`: 0.54-0.64 core per module with its two
  /// standbys against 0.42-0.43 without, at a calibrated wake-up of 14-22 us). It was 2 until then, which put
  /// soak-small at 2.1-3.6 cores when it used 1.1-1.3.
  static constexpr double kWakesPerStandby = 1.1;
  /// The middleware's delivery costs this many bare wake-ups per wake-up (data-sharing, listener hand-offs,
  /// history bookkeeping, the participants' event threads). Fitted with bench/scale.sh on this project's 2-core
  /// machines: 4.4 on 2026-11-28 (0.42-0.43 core per module at a calibrated 14-20 us, plant 50 us), 5.5 on
  /// 2026-11-24 (0.153 at 3.9 us, plant 43 us); 6.5, the 2026-11-24 fit with 8 modules, overestimated one module
  /// without standbys by 16-69% on 2026-11-28 (docs/benchmarks.md, "Capacity measured here").
  double dds_factor = 4.5;
  double ticks_per_s = 1000.0;
  /// Cores one module needs: ticks/s x (W x wake x dds_factor + plant + 2 x law).
  double core_per_module(const Calibration& c) const;
  /// Cores one standby robot adds.
  double core_per_standby(const Calibration& c) const;
};

/// "wake-up 17.2 us, plant step 31.0 us, law 1.9 us (calibrated in 0.21 s)".
std::string describe(const Calibration& c);

}  // namespace tandem::launcher
