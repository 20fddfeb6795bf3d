// A thread that spins in a per-tick process (docs/soak.md, finding 85): in a soak-small hour a restarted world's
// Fast DDS thread looped in user space inside libfastrtps 2.9.1 for 15 minutes at SCHED_FIFO. Its module never
// ran again, and the other processes queued behind it (load 34). No per-tick process ever needs most of a core
// for seconds: a world uses about 0.15-0.25 core, a robot or a supervisor under 0.1. So the launcher looks at the
// CPU of every thread of its local per-tick processes once a second, and a thread that used more than `share` of a
// core over the last `window_s` seconds is a fault: the process is killed and its exit handled as any crash's (a
// robot or supervisor restarted by its policy, a world's module failed).
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

namespace tandem::launcher {

/// One thread's CPU so far, from /proc.
struct ThreadTime {
  long tid = 0;
  double cpu_s = 0.0;  ///< user + system time since the thread started [s]
  int policy = 0;      ///< SCHED_OTHER 0, SCHED_FIFO 1, SCHED_RR 2, ...
};

/// The threads of a process (/proc/<pid>/task/*/stat); empty if it is gone.
std::vector<ThreadTime> thread_times(int pid);
/// A small /proc file whole, read with read(2); "" if it cannot be (the process or thread ended meanwhile). Not an
/// ifstream: its buffer throws when read(2) fails with ESRCH on a /proc file whose process is gone, and that took
/// `tandem up` down once in a soak hour (run 60: "basic_filebuf::underflow error reading the file: No such process").
std::string read_proc_text(const std::string& path);
/// The rest of an open file, read with read(2) (the fd stays open); "" if a read fails (ESRCH: its process is gone).
std::string read_fd_text(int fd);

/// "SCHED_FIFO", "SCHED_OTHER", ... for a policy number.
const char* policy_name(int policy);

struct ProcessThreads {
  int pid = 0;
  std::vector<ThreadTime> threads;
};

/// The rule, without /proc: fed one look at all watched processes at a time.
class SpinWatch {
 public:
  struct Spin {
    int pid = 0;
    long tid = 0;
    double share = 0.0;  ///< of a core, over `over_s`
    double over_s = 0.0;
    int policy = 0;
  };
  explicit SpinWatch(double share = 0.9, double window_s = 3.0) : share_(share), window_s_(window_s) {}
  /// One look at `now` [s]. Returns the threads that used more than share of a core over at least window_s (at
  /// most one per process; a process named once is not named again). Processes not in `procs` are forgotten.
  std::vector<Spin> look(double now, const std::vector<ProcessThreads>& procs);
  double share() const { return share_; }
  double window_s() const { return window_s_; }

 private:
  struct Seen {
    double t = 0.0, cpu_s = 0.0;
  };
  double share_, window_s_;
  std::map<std::pair<int, long>, std::vector<Seen>> seen_;  ///< (pid, tid): looks, oldest first
  std::map<int, bool> named_;                                ///< pid -> already returned
};

}  // namespace tandem::launcher
