// CPU hog for overload tests and soaks: one busy process per core, pinned, optionally SCHED_FIFO above the
// deployment, burning `busy` ms then sleeping `idle` ms, for `seconds`. Stops at SIGTERM/SIGINT; its children
// die with it (PR_SET_PDEATHSIG).
// usage: tandem_hog [--cores N] [--busy MS] [--idle MS] [--seconds S] [--fifo PRIO] [--nice N]
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "tandem/launcher/sched_group.hpp"

namespace {
volatile sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }
double now_s() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_nsec) * 1e-9;
}
}  // namespace

int main(int argc, char** argv) {
  int cores = static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN)), fifo = 0, nice = 0;
  double busy_ms = 30, idle_ms = 10, seconds = 2;
  for (int i = 1; i < argc; ++i) {
    const bool has = i + 1 < argc;
    if (std::strcmp(argv[i], "--cores") == 0 && has) cores = std::atoi(argv[++i]);
    else if (std::strcmp(argv[i], "--busy") == 0 && has) busy_ms = std::atof(argv[++i]);
    else if (std::strcmp(argv[i], "--idle") == 0 && has) idle_ms = std::atof(argv[++i]);
    else if (std::strcmp(argv[i], "--seconds") == 0 && has) seconds = std::atof(argv[++i]);
    else if (std::strcmp(argv[i], "--fifo") == 0 && has) fifo = std::atoi(argv[++i]);
    else if (std::strcmp(argv[i], "--nice") == 0 && has) nice = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: tandem_hog [--cores N] [--busy MS] [--idle MS] [--seconds S] [--fifo PRIO 1-98] [--nice N]\n");
      return 2;
    }
  }
  if (cores < 1 || cores > 256 || busy_ms <= 0 || idle_ms < 0 || seconds <= 0 || fifo < 0 || fifo > 98 || nice < -20 || nice > 19) {
    std::fprintf(stderr, "tandem_hog: --cores in [1, 256], --busy > 0, --idle >= 0, --seconds > 0, --fifo in [0, 98], --nice in [-20, 19]\n");
    return 2;
  }
  // Without SA_RESTART: a stop interrupts the waitpid below, which then passes it on to the busy processes (each in
  // a session of its own, so a terminal's Ctrl-C or a `kill` of this process reaches only this one).
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
  std::vector<pid_t> kids;
  for (int c = 0; c < cores; ++c) {
    const pid_t pid = fork();
    if (pid == 0) {
      prctl(PR_SET_PDEATHSIG, SIGTERM);
      // Each busy process as an unrelated program (a build's compiler, another user's job): a session and so a
      // scheduling autogroup of its own at its niceness (launcher/sched_group.hpp), not a share of the caller's.
      if (setpriority(PRIO_PROCESS, 0, nice) != 0) std::fprintf(stderr, "tandem_hog: niceness %d not permitted\n", nice);
      tandem::launcher::own_sched_group(nice);
      cpu_set_t set;
      CPU_ZERO(&set);
      CPU_SET(c % static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN)), &set);
      sched_setaffinity(0, sizeof set, &set);
      if (fifo > 0) {
        sched_param sp{};
        sp.sched_priority = fifo;
        if (sched_setscheduler(0, SCHED_FIFO, &sp) != 0) std::fprintf(stderr, "tandem_hog: SCHED_FIFO not permitted\n");
      }
      const double end = now_s() + seconds;
      volatile double x = 1.0;
      while (!g_stop && now_s() < end) {
        const double until = now_s() + busy_ms * 1e-3;
        while (now_s() < until) x = x * 1.0000001 + 1e-9;
        if (idle_ms > 0) usleep(static_cast<useconds_t>(idle_ms * 1e3));
      }
      _exit(0);
    }
    if (pid > 0) kids.push_back(pid);
  }
  for (pid_t k : kids) {
    while (waitpid(k, nullptr, 0) < 0 && !g_stop) {
    }
  }
  if (g_stop) {
    for (pid_t k : kids) kill(k, SIGTERM);
    for (pid_t k : kids) waitpid(k, nullptr, 0);
  }
  std::printf("hog: %d core(s), %.0f ms busy / %.0f ms idle, %.1f s%s\n", cores, busy_ms, idle_ms, seconds,
              fifo > 0 ? " (SCHED_FIFO)" : "");
  return 0;
}
