// The wake-up floor of the runtime's layout, with no middleware (bench/scale.sh runs it in the same run as the
// runtime and quotes the runtime as a ratio to it; docs/benchmarks.md, "Floor"). Per module: a world process on
// an absolute 1 kHz timer and two robot processes. Each tick the world wakes both robots through futexes in
// shared memory (a sample each), each robot burns `robot_us` of CPU (the control law's share) and wakes the
// world back (a command), and the world burns `world_us` (a plant step). Prints the CPU per module (user +
// system of its three processes over the run) and the share of ticks whose answers came after the deadline.
// Like the runtime's world (world::TickClock), a tick that starts more than half a period late re-anchors the
// clock, so a stall makes one late tick, not a burst of catch-up ticks.
// It also runs the world's overload rule (world::OverloadRule's defaults) on the floor's late ticks, to show how
// often the bare machine alone would trip it: trips of the running rule (more than max_late late ticks in a
// sliding window, or max_consecutive in a row) per module-minute, the longest run of late ticks, and the share of
// trial-sized blocks (trial_ticks) with more than 0, 1, 2, 5 and 10 late ticks (a late tick here is a tick with
// an arm late: 2 arm-ticks at most, counted as 1, so the floor's figures are a lower bound for the rule).
//
// usage: tandem_bench_floor --modules N --seconds S [--robot-us 10] [--world-us 30] [--fifo PRIO]
#include <linux/futex.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "tandem/world/world_core.hpp"

namespace {

long futex(int32_t* w, int op, int32_t v) { return ::syscall(SYS_futex, w, op, v, nullptr, nullptr, 0); }

int64_t now_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

void burn_us(double us) {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  const int64_t end = static_cast<int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec + static_cast<int64_t>(us * 1e3);
  for (;;) {
    ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    if (static_cast<int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec >= end) return;
  }
}

// Per module in shared memory: a sample word per robot (tick number to compute, -1 to stop) and a command
// counter the world waits on.
struct Slot {
  int32_t sample[2];
  int32_t answers;
  int32_t pad[13];
};

void set_fifo(int prio) {
  if (prio <= 0) return;
  sched_param sp{};
  sp.sched_priority = prio;
  (void)::sched_setscheduler(0, SCHED_FIFO, &sp);
}

double cpu_s(const rusage& ru) {
  return static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

}  // namespace

int main(int argc, char** argv) {
  int modules = 1, prio = 0;
  double seconds = 5.0, robot_us = 10.0, world_us = 30.0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    const double v = std::atof(argv[i + 1]);
    if (a == "--modules") modules = static_cast<int>(v);
    else if (a == "--seconds") seconds = v;
    else if (a == "--robot-us") robot_us = v;
    else if (a == "--world-us") world_us = v;
    else if (a == "--fifo") prio = static_cast<int>(v);
    else {
      std::fprintf(stderr, "usage: tandem_bench_floor --modules N --seconds S [--robot-us 10] [--world-us 30] [--fifo PRIO]\n");
      return 2;
    }
  }
  if (modules < 1 || modules > 64 || !(seconds > 0.0)) {
    std::fprintf(stderr, "tandem_bench_floor: --modules in [1, 64] and --seconds > 0\n");
    return 2;
  }
  const long ticks = static_cast<long>(seconds * 1000.0);
  const size_t flags_bytes = static_cast<size_t>(ticks) * static_cast<size_t>(modules);  // a late flag per tick
  const size_t bytes =
      sizeof(Slot) * static_cast<size_t>(modules) + sizeof(int64_t) * 2 * static_cast<size_t>(modules) + flags_bytes;
  void* mem = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  if (mem == MAP_FAILED) return 1;
  std::memset(mem, 0, bytes);
  auto* slots = static_cast<Slot*>(mem);
  auto* stats = reinterpret_cast<int64_t*>(slots + modules);  // per module: ticks, late ticks
  auto* late_flags = reinterpret_cast<uint8_t*>(stats + 2 * static_cast<size_t>(modules));
  std::vector<pid_t> pids;
  for (int m = 0; m < modules; ++m) {
    Slot* s = &slots[m];
    for (int j = 0; j < 2; ++j) {  // robots
      const pid_t p = ::fork();
      if (p == 0) {
        set_fifo(prio);
        int32_t seen = 0;
        for (;;) {
          int32_t v;
          while ((v = __atomic_load_n(&s->sample[j], __ATOMIC_ACQUIRE)) == seen) futex(&s->sample[j], FUTEX_WAIT, seen);
          if (v < 0) ::_exit(0);
          seen = v;
          burn_us(robot_us);
          __atomic_add_fetch(&s->answers, 1, __ATOMIC_RELEASE);
          futex(&s->answers, FUTEX_WAKE, 1);
        }
      }
      pids.push_back(p);
    }
    const pid_t w = ::fork();  // the world
    if (w == 0) {
      set_fifo(prio);
      int64_t next = now_ns();
      for (long k = 1; k <= ticks; ++k) {
        next += 1000000;
        timespec ts{static_cast<time_t>(next / 1000000000LL), static_cast<long>(next % 1000000000LL)};
        ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
        const int64_t woke = now_ns();
        if (woke - next > 500000) next = woke;  // re-anchor after a stall, as world::TickClock does
        const int32_t want = __atomic_load_n(&s->answers, __ATOMIC_ACQUIRE) + 2;
        for (int j = 0; j < 2; ++j) {
          __atomic_store_n(&s->sample[j], static_cast<int32_t>(k), __ATOMIC_RELEASE);
          futex(&s->sample[j], FUTEX_WAKE, 1);
        }
        int32_t a;
        while ((a = __atomic_load_n(&s->answers, __ATOMIC_ACQUIRE)) < want) futex(&s->answers, FUTEX_WAIT, a);
        if (now_ns() > next + 1000000) {
          ++stats[2 * static_cast<size_t>(m) + 1];
          late_flags[static_cast<size_t>(m) * static_cast<size_t>(ticks) + static_cast<size_t>(k - 1)] = 1;
        }
        burn_us(world_us);
        ++stats[2 * static_cast<size_t>(m)];
      }
      for (int j = 0; j < 2; ++j) {
        __atomic_store_n(&s->sample[j], -1, __ATOMIC_RELEASE);
        futex(&s->sample[j], FUTEX_WAKE, 1);
      }
      ::_exit(0);
    }
    pids.push_back(w);
  }
  double cpu = 0.0;
  for (const pid_t p : pids) {
    rusage ru{};
    int st = 0;
    if (::wait4(p, &st, 0, &ru) == p) cpu += cpu_s(ru);
  }
  long long total = 0, late = 0;
  for (int m = 0; m < modules; ++m) {
    total += stats[2 * static_cast<size_t>(m)];
    late += stats[2 * static_cast<size_t>(m) + 1];
  }
  std::printf("floor modules=%d seconds=%.1f robot_us=%.0f world_us=%.0f cpu_per_module=%.4f late=%.2f%%\n", modules,
              seconds, robot_us, world_us, cpu / seconds / modules, total > 0 ? 100.0 * static_cast<double>(late) / static_cast<double>(total) : 0.0);
  // The overload rule on the floor's late ticks.
  const tandem::world::OverloadRule rule;
  long trips = 0, longest = 0, blocks = 0;
  const int limits[] = {0, 1, 2, 5, 10};
  long over[5] = {0, 0, 0, 0, 0};
  for (int m = 0; m < modules; ++m) {
    const uint8_t* f = late_flags + static_cast<size_t>(m) * static_cast<size_t>(ticks);
    std::vector<uint8_t> ring(static_cast<size_t>(rule.window), 0);
    long in_window = 0, run = 0, block_late = 0;
    for (long k = 0; k < stats[2 * static_cast<size_t>(m)]; ++k) {
      uint8_t& slot = ring[static_cast<size_t>(k % rule.window)];
      in_window += f[k] - slot;
      slot = f[k];
      run = f[k] ? run + 1 : 0;
      longest = std::max(longest, run);
      if (in_window > rule.max_late || run >= rule.max_consecutive) {  // a trip: the window starts over
        ++trips;
        std::fill(ring.begin(), ring.end(), 0);
        in_window = 0;
        run = 0;
      }
      block_late += f[k];
      if ((k + 1) % rule.trial_ticks == 0) {
        ++blocks;
        for (int i = 0; i < 5; ++i) over[i] += block_late > limits[i] ? 1 : 0;
        block_late = 0;
      }
    }
  }
  const double b = static_cast<double>(std::max(1L, blocks));
  std::printf("floor rule: trips=%.2f/min longest_run=%ld trial_blocks=%ld late>0=%.1f%% >1=%.1f%% >2=%.1f%% >5=%.1f%% "
              ">10=%.1f%%\n",
              static_cast<double>(trips) / (seconds / 60.0) / modules, longest, blocks, 100.0 * static_cast<double>(over[0]) / b,
              100.0 * static_cast<double>(over[1]) / b, 100.0 * static_cast<double>(over[2]) / b,
              100.0 * static_cast<double>(over[3]) / b, 100.0 * static_cast<double>(over[4]) / b);
  ::munmap(mem, bytes);
  return 0;
}
