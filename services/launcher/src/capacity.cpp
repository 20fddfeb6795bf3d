#include "tandem/launcher/capacity.hpp"

#include <linux/futex.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <vector>

namespace tandem::launcher {
namespace {

long futex(int32_t* word, int op, int32_t value) {
  return ::syscall(SYS_futex, word, op, value, nullptr, nullptr, 0);
}

double cpu_s(const rusage& ru) {
  return static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

}  // namespace

Calibration calibrate_wakeup(int round_trips, int cpu) {
  Calibration c;
  const auto t0 = std::chrono::steady_clock::now();
  // Pinned: this thread (its mask put back at the end) and the child, which inherits it.
  cpu_set_t before_mask;
  CPU_ZERO(&before_mask);
  bool pinned = false;
  if (cpu >= 0 && cpu < CPU_SETSIZE && ::sched_getaffinity(0, sizeof before_mask, &before_mask) == 0) {
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(cpu, &one);
    pinned = ::sched_setaffinity(0, sizeof one, &one) == 0;
  }
  struct Restore {
    bool on;
    cpu_set_t* mask;
    ~Restore() {
      if (on) (void)::sched_setaffinity(0, sizeof *mask, mask);
    }
  } restore{pinned, &before_mask};
  // One word: 0 the parent's turn, 1 the child's, 2 the child leaves. After it, the child's CPU [s] at the start
  // and at the end of each block of ticks, written before it hands the turn back.
  constexpr int kBlocks = 5;
  const int per_block = std::max(1, round_trips / kBlocks);
  void* mem = ::mmap(nullptr, 4096, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  if (mem == MAP_FAILED) return c;
  auto* word = static_cast<int32_t*>(mem);
  auto* child_cpu = reinterpret_cast<double*>(static_cast<char*>(mem) + 64);  // kBlocks + 1 slots
  *word = 0;
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::munmap(mem, 4096);
    return c;
  }
  if (pid == 0) {
    rusage ru{};
    ::getrusage(RUSAGE_SELF, &ru);
    child_cpu[0] = cpu_s(ru);
    for (int n = 1;; ++n) {
      int32_t v;
      while ((v = __atomic_load_n(word, __ATOMIC_ACQUIRE)) == 0) futex(word, FUTEX_WAIT, 0);
      if (v == 2) ::_exit(0);
      if (n % per_block == 0 && n / per_block <= kBlocks) {
        ::getrusage(RUSAGE_SELF, &ru);  // the child has this one thread
        child_cpu[n / per_block] = cpu_s(ru);
      }
      __atomic_store_n(word, 0, __ATOMIC_RELEASE);
      futex(word, FUTEX_WAKE, 1);
    }
  }
  rusage before{}, after{}, child{};
  // The calling thread only: the launcher's participant may already have threads busy with discovery.
  ::getrusage(RUSAGE_THREAD, &before);
  std::vector<double> parent_cpu{cpu_s(before)};  // at the end of each block
  // Paced as a tick: the parent wakes on an absolute 1 ms timer, wakes the child, and waits for its answer, so
  // the cores go idle between ticks as they do in a running deployment (a wake-up from idle is what costs).
  timespec next{};
  ::clock_gettime(CLOCK_MONOTONIC, &next);
  for (int i = 0; i < round_trips; ++i) {
    next.tv_nsec += 1000000;
    if (next.tv_nsec >= 1000000000) {
      next.tv_nsec -= 1000000000;
      ++next.tv_sec;
    }
    ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
    __atomic_store_n(word, 1, __ATOMIC_RELEASE);
    futex(word, FUTEX_WAKE, 1);
    while (__atomic_load_n(word, __ATOMIC_ACQUIRE) == 1) futex(word, FUTEX_WAIT, 1);
    if ((i + 1) % per_block == 0 && (i + 1) / per_block <= kBlocks) {
      rusage ru{};
      ::getrusage(RUSAGE_THREAD, &ru);
      parent_cpu.push_back(cpu_s(ru));
    }
  }
  ::getrusage(RUSAGE_THREAD, &after);
  std::vector<double> per_wake;  // [us], one per block: both processes' CPU over its 3 wake-ups a tick
  for (size_t b = 1; b < parent_cpu.size(); ++b) {
    const double used = parent_cpu[b] - parent_cpu[b - 1] + child_cpu[b] - child_cpu[b - 1];
    per_wake.push_back(used / (3.0 * per_block) * 1e6);
  }
  __atomic_store_n(word, 2, __ATOMIC_RELEASE);
  futex(word, FUTEX_WAKE, 1);
  int status = 0;
  const bool reaped = ::wait4(pid, &status, 0, &child) == pid;
  ::munmap(mem, 4096);
  c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!reaped || round_trips <= 0) return c;
  const double cpu_used = cpu_s(after) - cpu_s(before) + cpu_s(child);
  // Per tick: the timer's, the child's and the parent's wake-up. The median block's, so that a burst of other work
  // in part of the calibration (a soak's observer starting its participant beside `tandem up`: 29-30 us against
  // 17-21 us alone, 2026-11-28) does not set the estimate; the whole run's mean if the blocks could not be read.
  c.wake_us = cpu_used / (3.0 * round_trips) * 1e6;
  if (per_wake.size() == static_cast<size_t>(kBlocks)) {
    std::sort(per_wake.begin(), per_wake.end());
    c.wake_us = per_wake[kBlocks / 2];
  }
  c.ok = c.wake_us > 0.0;
  return c;
}

double CapacityModel::core_per_module(const Calibration& c) const {
  return ticks_per_s * 1e-6 * (kWakesPerTick * c.wake_us * dds_factor + c.plant_us + 2.0 * c.law_us);
}

double CapacityModel::core_per_standby(const Calibration& c) const {
  return ticks_per_s * 1e-6 * (kWakesPerStandby * c.wake_us * dds_factor + c.law_us);
}

std::string describe(const Calibration& c) {
  char b[160];
  std::snprintf(b, sizeof b, "wake-up %.1f us, plant step %.1f us, law %.1f us (calibrated in %.2f s)", c.wake_us,
                c.plant_us, c.law_us, c.seconds);
  return b;
}

}  // namespace tandem::launcher
