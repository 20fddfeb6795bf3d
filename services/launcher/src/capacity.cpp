#include "tandem/launcher/capacity.hpp"

#include <linux/futex.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <time.h>

#include <chrono>
#include <cstdint>
#include <cstdio>

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
  // One word: 0 the parent's turn, 1 the child's, 2 the child leaves.
  void* mem = ::mmap(nullptr, 4096, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  if (mem == MAP_FAILED) return c;
  auto* word = static_cast<int32_t*>(mem);
  *word = 0;
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::munmap(mem, 4096);
    return c;
  }
  if (pid == 0) {
    for (;;) {
      int32_t v;
      while ((v = __atomic_load_n(word, __ATOMIC_ACQUIRE)) == 0) futex(word, FUTEX_WAIT, 0);
      if (v == 2) ::_exit(0);
      __atomic_store_n(word, 0, __ATOMIC_RELEASE);
      futex(word, FUTEX_WAKE, 1);
    }
  }
  rusage before{}, after{}, child{};
  ::getrusage(RUSAGE_SELF, &before);
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
  }
  ::getrusage(RUSAGE_SELF, &after);
  __atomic_store_n(word, 2, __ATOMIC_RELEASE);
  futex(word, FUTEX_WAKE, 1);
  int status = 0;
  const bool reaped = ::wait4(pid, &status, 0, &child) == pid;
  ::munmap(mem, 4096);
  c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!reaped || round_trips <= 0) return c;
  const double cpu_used = cpu_s(after) - cpu_s(before) + cpu_s(child);
  c.wake_us = cpu_used / (3.0 * round_trips) * 1e6;  // per tick: the timer's, the child's and the parent's wake-up
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
