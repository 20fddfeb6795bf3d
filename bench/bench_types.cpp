// What a module of each manipulator type costs per tick (docs/benchmarks.md, "Manipulator types"): the embedded
// module (sim::HostedModule: the world's plant, the supervisor and both robots' laws, the distributed processes'
// components in one process) of the paper's scenario (two identified 3R arms) beside the heterogeneous ones
// (3R + cartesian PPR, 3R + redundant planar 4R), all on the super-twisting case with eq. (37).
// R repetitions; in each, every scenario runs a batch of N ticks in turn (interleaved, so that slow phases of a
// shared machine hit them all). Reported: microseconds per tick (median, p10, p90 over the repetitions) and, per
// repetition, the ratio to the homogeneous module.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "tandem/sim/hosted_module.hpp"
#include "tandem/sim/module_setup.hpp"
#include "tandem/sim/scenario_yaml.hpp"

namespace {

namespace ts = tandem::sim;
using Clock = std::chrono::steady_clock;

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  const auto i = static_cast<size_t>(std::lround(p * static_cast<double>(v.size() - 1)));
  return v[std::min(i, v.size() - 1)];
}

struct Subject {
  std::string name;
  ts::ModuleSetup setup;
  std::vector<double> us_per_tick;
};

}  // namespace

int main(int argc, char** argv) {
  int reps = 15;
  long ticks = 1000;
  std::string dir = TANDEM_SOURCE_DIR "/config/scenarios";
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--help") == 0) {
      std::printf("usage: tandem_bench_types [--reps R] [--ticks N]\n\n"
                  "Microseconds per tick of the embedded module (world, supervisor, both robots) of paper.yaml, "
                  "hetero-ppr.yaml\nand hetero-4r.yaml (case SOSM-u), R interleaved repetitions of N ticks each "
                  "(defaults 15 and 1000).\n");
      return 0;
    }
    if (std::strcmp(argv[i], "--reps") == 0 && i + 1 < argc) {
      reps = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--ticks") == 0 && i + 1 < argc) {
      ticks = std::atol(argv[++i]);
    } else {
      std::fprintf(stderr, "tandem_bench_types: unknown argument '%s' (accepted: --reps R, --ticks N, --help)\n", argv[i]);
      return 2;
    }
  }
  if (reps < 1 || ticks < 1 || ticks > 5000) {
    std::fprintf(stderr, "tandem_bench_types: --reps must be >= 1 and --ticks in [1, 5000]\n");
    return 2;
  }
  std::vector<Subject> subjects;
  for (const char* name : {"paper", "hetero-ppr", "hetero-4r"}) {
    const ts::Scenario sc = ts::load_scenario(dir + "/" + name + ".yaml");
    for (const auto& c : sc.cases) {
      if (c.name == "SOSM-u") subjects.push_back({name, ts::make_module(sc, c), {}});
    }
  }
  if (subjects.size() != 3) {
    std::fprintf(stderr, "tandem_bench_types: a scenario has no SOSM-u case\n");
    return 1;
  }
  std::vector<std::vector<double>> ratio(subjects.size());
  for (int r = -1; r < reps; ++r) {  // r = -1: warm-up, not kept
    std::vector<double> this_rep;
    for (Subject& s : subjects) {
      ts::HostedModule mod(s.setup, 0.1);
      const auto t0 = Clock::now();
      for (long k = 0; k < ticks; ++k) {
        if (!mod.tick()) {
          std::fprintf(stderr, "tandem_bench_types: %s stopped at tick %ld\n", s.name.c_str(), k);
          return 1;
        }
      }
      const double us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count() / static_cast<double>(ticks);
      this_rep.push_back(us);
      if (r >= 0) s.us_per_tick.push_back(us);
    }
    if (r >= 0) {
      for (size_t i = 0; i < subjects.size(); ++i) ratio[i].push_back(this_rep[i] / this_rep[0]);
    }
  }
  std::printf("%-11s %12s %10s %10s %18s\n", "module", "us/tick p50", "p10", "p90", "ratio to paper p50");
  for (size_t i = 0; i < subjects.size(); ++i) {
    const Subject& s = subjects[i];
    std::printf("%-11s %12.1f %10.1f %10.1f %18.2f\n", s.name.c_str(), percentile(s.us_per_tick, 0.5),
                percentile(s.us_per_tick, 0.1), percentile(s.us_per_tick, 0.9), percentile(ratio[i], 0.5));
  }
  return 0;
}
