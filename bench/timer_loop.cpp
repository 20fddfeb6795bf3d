// A bare 1 kHz loop on absolute clock_nanosleep deadlines, nothing else in it: the floor that every
// real-time figure of bench/scale.sh is set beside (run in the same run, at the same scheduling).
// Prints key=value lines: wake-up lateness p50/p99/max and the fraction of ticks more than 0.5 ms late.
// Usage: tandem_bench_timer [--seconds S] [--fifo PRIO]
#include <sched.h>
#include <signal.h>
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace {
volatile sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }
}  // namespace

// Stops at the end of --seconds or at SIGINT/SIGTERM, and prints what it measured either way.
int main(int argc, char** argv) {
  signal(SIGTERM, on_signal);
  signal(SIGINT, on_signal);
  double seconds = 10.0;
  int fifo = 0;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--seconds") == 0 && i + 1 < argc) {
      seconds = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--fifo") == 0 && i + 1 < argc) {
      fifo = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: tandem_bench_timer [--seconds S (0.1-36000)] [--fifo PRIO (1-98)]\n");
      return 2;
    }
  }
  if (!(seconds >= 0.1 && seconds <= 36000.0) || fifo < 0 || fifo > 98) {
    std::fprintf(stderr, "tandem_bench_timer: --seconds must be in [0.1, 36000], --fifo in [0, 98]\n");
    return 2;
  }
  if (fifo > 0) {
    sched_param sp{};
    sp.sched_priority = fifo;
    if (sched_setscheduler(0, SCHED_FIFO, &sp) != 0) std::printf("timer_fifo=not_permitted\n");
  }
  const long period = 1000000;
  const long n = static_cast<long>(seconds * 1000.0);
  std::vector<double> late_us;
  late_us.reserve(static_cast<size_t>(n));
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  for (long k = 0; k < n && !g_stop; ++k) {
    next.tv_nsec += period;
    while (next.tv_nsec >= 1000000000L) {
      next.tv_nsec -= 1000000000L;
      ++next.tv_sec;
    }
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
    timespec now{};
    clock_gettime(CLOCK_MONOTONIC, &now);
    const double l = static_cast<double>((now.tv_sec - next.tv_sec) * 1000000000L + (now.tv_nsec - next.tv_nsec)) * 1e-3;
    late_us.push_back(l);
    if (l > 1000.0) next = now;  // re-anchor after a stall, as the world does
  }
  if (late_us.empty()) return 1;
  std::vector<double> s = late_us;
  std::sort(s.begin(), s.end());
  const auto pct = [&](double p) { return s[std::min(s.size() - 1, static_cast<size_t>(p * static_cast<double>(s.size())))]; };
  const long over = std::count_if(s.begin(), s.end(), [](double v) { return v > 500.0; });
  std::printf("timer_ticks=%zu\ntimer_late_p50_us=%.1f\ntimer_late_p99_us=%.1f\ntimer_late_max_us=%.1f\n"
              "timer_late_fraction=%.5f\n",
              s.size(), pct(0.5), pct(0.99), s.back(), static_cast<double>(over) / static_cast<double>(s.size()));
  return 0;
}
