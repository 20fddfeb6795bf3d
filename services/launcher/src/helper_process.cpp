// A helper process of `tandem up` (helper_process.hpp).
#include "tandem/launcher/helper_process.hpp"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <utility>

namespace tandem::launcher {

HelperProcess::HelperProcess(int pid, double grace_s, std::string kill_note)
    : pid_(pid), grace_s_(grace_s), kill_note_(std::move(kill_note)) {}

bool HelperProcess::exited() {
  if (pid_ <= 0) return false;
  int st = 0;
  const pid_t r = ::waitpid(pid_, &st, WNOHANG);
  if (r == 0 || (r < 0 && errno != ECHILD)) return false;
  if (r == pid_) status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  pid_ = -1;  // reaped now, or not a child of ours any more
  return true;
}

void HelperProcess::stop() {
  if (pid_ <= 0) return;
  ::kill(pid_, SIGTERM);
  const long polls = std::lround(grace_s_ / 0.02);  // of 20 ms
  for (long i = 0; i < polls; ++i) {
    if (exited()) return;
    ::usleep(20000);
  }
  if (exited()) return;
  if (!kill_note_.empty()) std::fprintf(stderr, "%s", kill_note_.c_str());
  ::kill(pid_, SIGKILL);
  ::waitpid(pid_, nullptr, 0);
  status_ = 128 + SIGKILL;
  pid_ = -1;
}

}  // namespace tandem::launcher
