// Scheduling autogroups (Linux, CONFIG_SCHED_AUTOGROUP, on by default in Debian's kernels): the fair scheduler
// first shares the CPU between sessions (one autogroup per session, weighted by the group's own nice value) and
// only then between the threads of a session by their niceness. A niceness of -10 therefore ranks a process
// ahead of load started in its own session and not ahead of a build running in another terminal. A process that
// leads its own session gets its own group, whose nice value it sets by writing /proc/self/autogroup
// (docs/architecture.md, "Real-time timing"). Header only and async-signal-safe: used between fork and exec.
#pragma once

#include <fcntl.h>
#include <unistd.h>

namespace tandem::launcher {

/// Writes `nice` as the nice value of this process's autogroup. False where the kernel has no autogroups, has
/// them disabled (the write then fails), or does not permit the value (a negative one needs CAP_SYS_NICE).
/// Only meaningful for a process that leads its own session (see own_sched_group): otherwise the group is the
/// session of the shell that started it, shared with everything else started there.
inline bool set_autogroup_nice(int nice) {
  char text[8];
  int n = 0;
  unsigned v = static_cast<unsigned>(nice < 0 ? -nice : nice);
  char digits[4];
  int k = 0;
  do {
    digits[k++] = static_cast<char>('0' + v % 10);
    v /= 10;
  } while (v != 0 && k < 4);
  if (nice < 0) text[n++] = '-';
  while (k > 0) text[n++] = digits[--k];
  const int fd = ::open("/proc/self/autogroup", O_WRONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool ok = ::write(fd, text, static_cast<size_t>(n)) == n;
  ::close(fd);
  return ok;
}

/// Whether this process leads its own session (and so its own autogroup).
inline bool leads_session() { return ::getsid(0) == ::getpid(); }

/// For a freshly forked child: a session (and so an autogroup) of its own, weighted like the niceness it inherited,
/// so that the scheduler ranks it against other sessions' load as its niceness ranks it within one. The child
/// then gets no terminal signals (Ctrl-C goes to the launcher, which stops its children itself).
inline void own_sched_group(int inherited_nice) {
  if (::setsid() < 0) return;
  (void)set_autogroup_nice(inherited_nice);
}

}  // namespace tandem::launcher
