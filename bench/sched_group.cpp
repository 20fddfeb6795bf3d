// What an autogroup of its own buys a control-plane process (launcher/sched_group.hpp) against another session's
// load: two busy processes in a session of their own (a build in another terminal, the soak's hog faults) and a
// probe at the control plane's niceness (launcher::kServiceNice) that needs a fixed amount of CPU (a process's
// start-up) and then wakes every millisecond (a supervisor's or coordinator's timer). The probe runs either in
// the caller's session, as every child of the launcher did before, or in a session and autogroup of its own
// (launcher::own_sched_group, as launcher::spawn does now); a run with no load is the floor.
// Usage: tandem_bench_sched_group [runs=5] [work_ms=100]   (docs/benchmarks.md, "Scheduling groups")
#include "tandem/launcher/sched_group.hpp"
#include "tandem/launcher/spawn.hpp"

#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <vector>

namespace {

double now(clockid_t c) {
  timespec t{};
  ::clock_gettime(c, &t);
  return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_nsec) * 1e-9;
}

struct Probe {
  double start_wall_ms = 0;  // wall time to get work_ms of CPU
  double late_p99_us = 0;    // lateness of 1 ms wake-ups
};

// Runs in the forked probe; writes its result into the pipe.
void probe(int fd, bool own_group, int work_ms) {
  (void)::setpriority(PRIO_PROCESS, 0, tandem::launcher::kServiceNice);
  if (own_group) tandem::launcher::own_sched_group(tandem::launcher::kServiceNice);
  Probe r;
  const double w0 = now(CLOCK_MONOTONIC);
  const double c0 = now(CLOCK_THREAD_CPUTIME_ID);
  volatile double sink = 0;
  while (now(CLOCK_THREAD_CPUTIME_ID) - c0 < work_ms * 1e-3) sink = sink + 1.0;
  r.start_wall_ms = (now(CLOCK_MONOTONIC) - w0) * 1e3;
  std::vector<double> late;
  timespec next{};
  ::clock_gettime(CLOCK_MONOTONIC, &next);
  for (int i = 0; i < 2000; ++i) {
    next.tv_nsec += 1000000;
    if (next.tv_nsec >= 1000000000) {
      next.tv_nsec -= 1000000000;
      ++next.tv_sec;
    }
    ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
    const double due = static_cast<double>(next.tv_sec) + static_cast<double>(next.tv_nsec) * 1e-9;
    late.push_back((now(CLOCK_MONOTONIC) - due) * 1e6);
    for (int k = 0; k < 20000; ++k) sink = sink + 1.0;  // a little work per wake-up
  }
  std::sort(late.begin(), late.end());
  r.late_p99_us = late[late.size() * 99 / 100];
  (void)!::write(fd, &r, sizeof r);
  ::_exit(0);
}

Probe run(bool own_group, int work_ms) {
  int p[2];
  if (::pipe(p) != 0) std::exit(1);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(p[0]);
    probe(p[1], own_group, work_ms);
  }
  ::close(p[1]);
  Probe r;
  if (::read(p[0], &r, sizeof r) != static_cast<ssize_t>(sizeof r)) std::exit(1);
  ::close(p[0]);
  ::waitpid(pid, nullptr, 0);
  return r;
}

std::vector<pid_t> start_hogs(int n) {
  std::vector<pid_t> hogs;
  for (int i = 0; i < n; ++i) {
    const pid_t pid = ::fork();
    if (pid == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      (void)::setpriority(PRIO_PROCESS, 0, 0);
      tandem::launcher::own_sched_group(0);
      volatile unsigned long x = 0;
      for (;;) x = x + 1;
    }
    hogs.push_back(pid);
  }
  return hogs;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const int runs = argc > 1 ? std::atoi(argv[1]) : 5;
  const int work_ms = argc > 2 ? std::atoi(argv[2]) : 100;
  if (runs < 1 || runs > 100 || work_ms < 1 || work_ms > 10000) {
    std::fprintf(stderr, "usage: tandem_bench_sched_group [runs in 1..100] [work_ms in 1..10000]\n");
    return 2;
  }
  errno = 0;
  if (::setpriority(PRIO_PROCESS, 0, tandem::launcher::kServiceNice) != 0) {
    std::fprintf(stderr, "tandem_bench_sched_group: niceness %d not permitted (needs CAP_SYS_NICE)\n",
                 tandem::launcher::kServiceNice);
    return 2;
  }
  (void)::setpriority(PRIO_PROCESS, 0, 0);
  std::FILE* f = std::fopen("/proc/sys/kernel/sched_autogroup_enabled", "r");
  int enabled = -1;
  if (f != nullptr) {
    if (std::fscanf(f, "%d", &enabled) != 1) enabled = -1;
    std::fclose(f);
  }
  std::printf("sched_autogroup_enabled=%d, %d runs, probe: %d ms of CPU, then 2000 wake-ups at 1 kHz, niceness %d\n",
              enabled, runs, work_ms, tandem::launcher::kServiceNice);
  std::printf("%-36s %16s %16s\n", "case", "start wall ms", "wake p99 us");
  struct Case {
    const char* name;
    int hogs;
    bool own;
  };
  for (const Case c : {Case{"no load (floor)", 0, false}, Case{"2 hogs, probe in the caller's session", 2, false},
                       Case{"2 hogs, probe in its own group", 2, true}}) {
    std::vector<double> wall, p99;
    for (int i = 0; i < runs; ++i) {
      auto hogs = start_hogs(c.hogs);
      struct timespec settle {0, 200000000};
      ::nanosleep(&settle, nullptr);
      const Probe r = run(c.own, work_ms);
      for (pid_t h : hogs) {
        ::kill(h, SIGKILL);
        ::waitpid(h, nullptr, 0);
      }
      wall.push_back(r.start_wall_ms);
      p99.push_back(r.late_p99_us);
    }
    std::printf("%-36s %16.1f %16.0f\n", c.name, median(wall), median(p99));
  }
  return 0;
}
