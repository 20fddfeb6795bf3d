// Micro-benchmark of the two hot paths of the embedded simulation (docs/benchmarks.md):
//  - one control step, HybridController::step, for the sliding-mode, super-twisting and PD laws
//    (selection (1,0,1), sensors read from a running plant);
//  - one plant step, ModulePlant::step over the 1 ms period with 10 RK4 substeps, and one RK4 substep
//    alone (dt = 0.1 ms, substeps = 1).
// Plain std::chrono::steady_clock: after a warm-up, R repetitions of a batch of N calls per benchmark,
// the benchmarks interleaved within each repetition so that slow phases of a shared machine hit them all.
// Reported: ns per call over the batches (median, p10, p90, min), plus the plant/control ratio and the
// real-time factor of the embedded loop, both computed per repetition.
//
// The inputs are recorded once from a closed-loop run of the paper's module (services/sim/src/embedded.cpp
// set-up, sliding-mode law on both arms) while the object moves, so every call sees a different, realistic
// state: the controller gets the sensors and reference of arm 1 at successive periods, and the plant
// replays the recorded torques from a copy of the plant taken at the start of the window.

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "tandem/model/arm.hpp"
#include "tandem/model/controller.hpp"
#include "tandem/model/grasp.hpp"
#include "tandem/model/plant.hpp"
#include "tandem/model/reference.hpp"

namespace {

namespace mdl = tandem::model;
using mdl::Vec3;
using Clock = std::chrono::steady_clock;

constexpr double kPeriod = 1.0e-3;  // control period [s]
constexpr int kSubsteps = 10;       // RK4 substeps per period
constexpr int kBenchArm = 1;  // the hybrid arm, selection (1, 0, 1)

// Whatever the timed loops compute ends up here, so the compiler cannot drop the work.
volatile double g_sink = 0.0;

struct Options {
  bool csv = false;
  int reps = 31;
  int warmup = 3;        // discarded batches per benchmark before the measured ones
  int control_n = 2000;  // calls per batch
  int plant_n = 500;
  int substep_n = 5000;  // 0.5 s of simulated time, like the plant batch
};

void print_help() {
  std::printf(
      "usage: tandem_bench_step [--csv] [--reps R] [--help]\n"
      "\n"
      "Micro-benchmark of one control step (HybridController::step, laws sliding_mode, super_twisting, pd)\n"
      "and one plant step (ModulePlant::step, 1 ms with %d RK4 substeps; and one RK4 substep alone).\n"
      "Each benchmark runs R batches (default 31, interleaved) of N calls (control 2000, plant 500,\n"
      "RK4 substep 5000) after a warm-up, and reports ns per call over the batches: median, p10, p90, min.\n"
      "\n"
      "  --csv      print CSV instead of the table\n"
      "  --reps R   number of measured batches per benchmark (>= 1)\n"
      "  --help     print this help\n",
      kSubsteps);
}

bool parse_int(const char* s, int lo, int& out) {
  char* end = nullptr;
  const long v = std::strtol(s, &end, 10);
  if (end == s || *end != '\0' || v < lo || v > 1000000) return false;
  out = static_cast<int>(v);
  return true;
}

// ---- module set-up (as in services/sim/src/embedded.cpp with config/scenarios/paper.yaml) ---------------

mdl::ModuleParams module_params() {
  mdl::ModuleParams mp;
  mp.arms[0] = mdl::smart3s2();
  mp.arms[1] = mdl::smart3s2();
  mp.arms[0].base = {-1.0, 0.0};
  mp.arms[1].base = {1.0, 0.0};
  return mp;  // object and contact defaults are the paper's
}

mdl::HybridParams hybrid_params(int j, mdl::LawType law, double k_normal) {
  mdl::HybridParams hp;
  hp.selection_p = j == 0 ? Vec3(1.0, 1.0, 1.0) : Vec3(1.0, 0.0, 1.0);
  hp.contact_stiffness = k_normal;
  hp.law.type = law;
  hp.period = kPeriod;
  return hp;
}

/// Inputs recorded from the closed loop over a window of `steps` periods starting at t0.
struct Recording {
  explicit Recording(const mdl::ModuleParams& mp) : plant_at_start(mp) {}
  mdl::ModulePlant plant_at_start;  ///< copy of the plant at t0 (state, anchors, counters)
  double t0 = 0.0;
  std::vector<mdl::ArmSensors> sensors;  ///< arm kBenchArm, period k
  std::vector<mdl::ArmReference> refs;   ///< arm kBenchArm, period k
  std::vector<std::array<Vec3, 2>> tau;  ///< torques of both arms applied over period k
};

/// Runs the module in closed loop (sliding mode on both arms) for `lead` periods, then records `steps`
/// periods. Returns false if the simulation diverged or the grasp opened.
bool record(const mdl::ModuleParams& mp, long lead, long steps, Recording& rec) {
  const double h_ref = 1.5 * mdl::safe_grasp_force(mp.object.mass, mp.object.mu_s, mp.g0);
  mdl::GraspGeometry geom;
  geom.stick_length[0] = geom.stick_length[1] = mp.object.half_width;
  geom.preload = h_ref / mp.contact.k_normal;
  const mdl::ObjectPath path(Vec3(-0.2, 0.8, 0.0), 0.5, {{Vec3(0.2, 0.8, 0.0), 4.0}});

  mdl::ModuleState init;
  const mdl::PoseSample p0 = path.sample(0.0);
  const double elbow[2] = {-1.0, 1.0};
  for (int j = 0; j < 2; ++j) {
    const mdl::ArmReference r0 = mdl::arm_reference(j, p0, geom, h_ref);
    Vec3 q0;
    if (!mdl::inverse_kinematics(mp.arms[j], r0.x, elbow[j], q0)) return false;
    init.q[j] = q0;
  }
  init.c = p0.pose.head<2>();
  init.psi = -p0.pose(2);
  mdl::ModulePlant plant(mp);
  plant.reset(init);
  std::array<mdl::HybridController, 2> ctl{
      mdl::HybridController(mp.arms[0], hybrid_params(0, mdl::LawType::SlidingMode, mp.contact.k_normal)),
      mdl::HybridController(mp.arms[1], hybrid_params(1, mdl::LawType::SlidingMode, mp.contact.k_normal))};

  rec.sensors.clear();
  rec.refs.clear();
  rec.tau.clear();
  for (long k = 0; k < lead + steps; ++k) {
    const double t = static_cast<double>(k) * kPeriod;
    if (k == lead) {
      rec.plant_at_start = plant;
      rec.t0 = t;
    }
    const mdl::PoseSample ps = path.sample(t);
    const mdl::ContactReading contact = plant.contacts();
    std::array<Vec3, 2> tau;
    for (int j = 0; j < 2; ++j) {
      const mdl::ArmReference ref = mdl::arm_reference(j, ps, geom, h_ref);
      mdl::ArmSensors in;
      in.q = plant.state().q[j];
      in.qd = plant.state().qd[j];
      in.h = contact.h[j];
      tau[j] = ctl[j].step(in, ref).tau;
      if (k >= lead && j == kBenchArm) {
        rec.sensors.push_back(in);
        rec.refs.push_back(ref);
      }
    }
    if (k >= lead) rec.tau.push_back(tau);
    plant.step(tau, t, kPeriod, kSubsteps);
    const mdl::ModuleState& st = plant.state();
    if (!st.c.allFinite() || !st.q[0].allFinite() || !st.q[1].allFinite()) return false;
  }
  return plant.counters().contact_lost == 0;
}

// ---- timing ----------------------------------------------------------------------------------------

struct Bench {
  std::string name;   ///< CSV name
  std::string label;  ///< table label
  int calls = 0;
  std::function<double()> batch;  ///< runs one batch, returns ns per call
  std::vector<double> ns;         ///< measured batches
};

double elapsed_ns(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::nano>(b - a).count();
}

Bench control_bench(const std::string& law_name, mdl::LawType law, const mdl::ModuleParams& mp,
                    const Recording& rec, int n) {
  Bench b;
  b.name = "control_step_" + law_name;
  b.label = "control step, " + law_name;
  b.calls = n;
  const mdl::HybridParams hp = hybrid_params(kBenchArm, law, mp.contact.k_normal);
  b.batch = [ctl = mdl::HybridController(mp.arms[kBenchArm], hp), &rec, n]() mutable {
    ctl.reset();  // same law memory at the start of every batch
    double acc = 0.0;
    const auto t_start = Clock::now();
    for (int i = 0; i < n; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const mdl::ControlOutput out = ctl.step(rec.sensors[k], rec.refs[k]);
      acc += out.tau(0) + out.tau(1) + out.tau(2);
    }
    const auto t_end = Clock::now();
    g_sink = g_sink + acc;
    return elapsed_ns(t_start, t_end) / n;
  };
  return b;
}

/// Replays the recorded torques from the recorded plant: `per_period` calls of ModulePlant::step with
/// dt = kPeriod / per_period and kSubsteps / per_period RK4 substeps each, per control period.
Bench plant_bench(const std::string& name, const std::string& label, const Recording& rec, int n,
                  int per_period) {
  Bench b;
  b.name = name;
  b.label = label;
  b.calls = n;
  const double dt = kPeriod / per_period;
  const int substeps = kSubsteps / per_period;
  b.batch = [plant = rec.plant_at_start, &rec, n, per_period, dt, substeps]() mutable {
    plant = rec.plant_at_start;  // same trajectory in every batch
    double acc = 0.0;
    const auto t_start = Clock::now();
    for (int i = 0; i < n; ++i) {
      const auto k = static_cast<std::size_t>(i / per_period);
      plant.step(rec.tau[k], rec.t0 + i * dt, dt, substeps);
      acc += plant.state().c(0) + plant.state().q[0](0) + plant.state().q[1](2);
    }
    const auto t_end = Clock::now();
    g_sink = g_sink + acc;
    return elapsed_ns(t_start, t_end) / n;
  };
  return b;
}

struct Stats {
  double median = 0.0, p10 = 0.0, p90 = 0.0, min = 0.0;
};

/// Quantile by linear interpolation between order statistics (v sorted, non-empty).
double quantile(const std::vector<double>& v, double q) {
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  const double f = pos - static_cast<double>(lo);
  return v[lo] + f * (v[hi] - v[lo]);
}

Stats stats(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  Stats s;
  s.median = quantile(v, 0.5);
  s.p10 = quantile(v, 0.1);
  s.p90 = quantile(v, 0.9);
  s.min = v.front();
  return s;
}

struct Row {
  std::string name, label, unit;
  int calls = 0;
  Stats s;
};

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0) {
      print_help();
      return 0;
    }
    if (std::strcmp(argv[i], "--csv") == 0) {
      opt.csv = true;
    } else if (std::strcmp(argv[i], "--reps") == 0 && i + 1 < argc && parse_int(argv[i + 1], 1, opt.reps)) {
      ++i;
    } else {
      std::fprintf(stderr, "tandem_bench_step: bad argument '%s' (see --help)\n", argv[i]);
      return 2;
    }
  }

  const mdl::ModuleParams mp = module_params();
  Recording rec(mp);
  const long window = std::max({opt.control_n, opt.plant_n, opt.substep_n / kSubsteps});
  if (!record(mp, 1000, window, rec)) {  // 0.5 s hold + 0.5 s of motion, then the window
    std::fprintf(stderr, "tandem_bench_step: the closed-loop recording diverged or lost the grasp\n");
    return 1;
  }

  std::vector<Bench> benches;
  benches.push_back(control_bench("sliding_mode", mdl::LawType::SlidingMode, mp, rec, opt.control_n));
  benches.push_back(control_bench("super_twisting", mdl::LawType::SuperTwisting, mp, rec, opt.control_n));
  benches.push_back(control_bench("pd", mdl::LawType::PD, mp, rec, opt.control_n));
  benches.push_back(plant_bench("plant_step", "plant step (1 ms, 10 x RK4)", rec, opt.plant_n, 1));
  benches.push_back(plant_bench("rk4_substep", "RK4 substep (0.1 ms)", rec, opt.substep_n, kSubsteps));
  const std::size_t kPlant = 3;

  for (int w = 0; w < opt.warmup; ++w) {
    for (auto& b : benches) g_sink = g_sink + b.batch();
  }
  for (int r = 0; r < opt.reps; ++r) {
    for (auto& b : benches) b.ns.push_back(b.batch());
  }

  std::vector<Row> rows;
  rows.reserve(benches.size());
  for (const auto& b : benches) rows.push_back({b.name, b.label, "ns", b.calls, stats(b.ns)});
  // Derived quantities, computed per repetition (the batches of one repetition ran back to back).
  const auto reps = static_cast<std::size_t>(opt.reps);
  for (std::size_t c = 0; c < kPlant; ++c) {
    const std::string law = benches[c].name.substr(std::strlen("control_step_"));
    std::vector<double> ratio(reps), rtf(reps), cycle(reps);
    for (std::size_t r = 0; r < reps; ++r) {
      ratio[r] = benches[kPlant].ns[r] / benches[c].ns[r];
      cycle[r] = benches[kPlant].ns[r] + 2.0 * benches[c].ns[r];
      rtf[r] = kPeriod * 1e9 / cycle[r];
    }
    rows.push_back({"ratio_plant_over_control_" + law, "plant / control step, " + law, "x", 0, stats(ratio)});
    rows.push_back({"sim_period_" + law, "plant + 2 control steps, " + law, "ns", 0, stats(cycle)});
    rows.push_back({"real_time_factor_" + law, "real-time factor, " + law, "x", 0, stats(rtf)});
  }

  if (opt.csv) {
    std::printf("name,unit,calls_per_batch,batches,median,p10,p90,min\n");
    for (const auto& r : rows) {
      std::printf("%s,%s,%d,%d,%.6g,%.6g,%.6g,%.6g\n", r.name.c_str(), r.unit.c_str(), r.calls, opt.reps,
                  r.s.median, r.s.p10, r.s.p90, r.s.min);
    }
  } else {
    std::printf("tandem_bench_step: %d batches per benchmark after %d warm-up batches, interleaved\n",
                opt.reps, opt.warmup);
    std::printf(
        "(ns per call over the batches; the ratio plant / control step, the simulated period\n"
        " plant + 2 control steps and the real-time factor 1 ms / (plant + 2 control steps) are\n"
        " computed per repetition)\n\n");
    std::printf("%-40s %6s %11s %11s %11s %11s  %s\n", "benchmark", "calls", "median", "p10", "p90", "min",
                "unit");
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const Row& r = rows[i];
      if (i == benches.size()) std::printf("\n");
      const std::string calls = r.calls > 0 ? std::to_string(r.calls) : "";
      const int prec = r.unit == "x" ? 2 : 1;
      std::printf("%-40s %6s %11.*f %11.*f %11.*f %11.*f  %s\n", r.label.c_str(), calls.c_str(), prec,
                  r.s.median, prec, r.s.p10, prec, r.s.p90, prec, r.s.min, r.unit.c_str());
    }
    const Stats& sm = rows[0].s;
    const Stats& pl = rows[kPlant].s;
    std::printf(
        "\ntargets: control step < 20 us (median %.2f us for sliding_mode, %.3f%% of the 1 ms"
        " period);\n",
        sm.median * 1e-3, sm.median / (kPeriod * 1e9) * 100.0);
    std::printf("         plant step < 200 us per 1 ms step (median %.2f us)\n", pl.median * 1e-3);
  }
  return 0;
}
