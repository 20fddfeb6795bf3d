#include "tandem/launcher/spin_watch.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <set>
#include <sstream>
#include <string>

namespace tandem::launcher {

std::string read_fd_text(int fd) {
  std::string text;
  char buf[1024];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return "";  // cut short: no half a line
    if (n == 0) return text;
    text.append(buf, static_cast<size_t>(n));
  }
}

std::string read_proc_text(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return "";
  std::string text = read_fd_text(fd);
  ::close(fd);
  return text;
}

std::vector<ThreadTime> thread_times(int pid) {
  std::vector<ThreadTime> out;
  const std::string dir = "/proc/" + std::to_string(pid) + "/task";
  DIR* d = ::opendir(dir.c_str());
  if (d == nullptr) return out;
  static const double hz = static_cast<double>(::sysconf(_SC_CLK_TCK));
  while (const dirent* e = ::readdir(d)) {
    if (e->d_name[0] < '0' || e->d_name[0] > '9') continue;
    const std::string text = read_proc_text(dir + "/" + e->d_name + "/stat");
    const auto close = text.rfind(')');  // the thread's name may hold spaces and parentheses
    if (close == std::string::npos) continue;  // it ended meanwhile
    std::istringstream rest(text.substr(close + 1));
    std::vector<std::string> fields;  // from field 3 (state) on
    for (std::string w; rest >> w;) fields.push_back(w);
    if (fields.size() < 39) continue;
    ThreadTime t;
    t.tid = std::atol(e->d_name);
    t.cpu_s = (std::strtod(fields[11].c_str(), nullptr) + std::strtod(fields[12].c_str(), nullptr)) / hz;  // 14, 15
    t.policy = std::atoi(fields[38].c_str());                                                               // 41
    out.push_back(t);
  }
  ::closedir(d);
  return out;
}

const char* policy_name(int policy) {
  switch (policy) {
    case 0: return "SCHED_OTHER";
    case 1: return "SCHED_FIFO";
    case 2: return "SCHED_RR";
    case 3: return "SCHED_BATCH";
    case 5: return "SCHED_IDLE";
    case 6: return "SCHED_DEADLINE";
    default: return "an unknown policy";
  }
}

std::vector<SpinWatch::Spin> SpinWatch::look(double now, const std::vector<ProcessThreads>& procs) {
  std::vector<Spin> out;
  std::set<std::pair<int, long>> present;
  std::set<int> pids;
  for (const ProcessThreads& p : procs) {
    pids.insert(p.pid);
    bool found = false;
    for (const ThreadTime& th : p.threads) {
      const auto key = std::make_pair(p.pid, th.tid);
      present.insert(key);
      std::vector<Seen>& s = seen_[key];
      s.push_back({now, th.cpu_s});
      // Keep the newest look at least window_s old (the base) and everything after it.
      size_t base = 0;
      for (size_t i = 0; i + 1 < s.size(); ++i) {
        if (now - s[i].t >= window_s_) base = i;
      }
      if (base > 0) s.erase(s.begin(), s.begin() + static_cast<long>(base));
      const Seen& b = s.front();
      const double over = now - b.t;
      if (found || named_[p.pid] || over < window_s_ || over <= 0.0) continue;
      const double share = (th.cpu_s - b.cpu_s) / over;
      if (share > share_) {
        out.push_back({p.pid, th.tid, share, over, th.policy});
        found = true;
      }
    }
    if (found) named_[p.pid] = true;
  }
  for (auto it = seen_.begin(); it != seen_.end();) it = present.count(it->first) ? std::next(it) : seen_.erase(it);
  for (auto it = named_.begin(); it != named_.end();) it = pids.count(it->first) ? std::next(it) : named_.erase(it);
  return out;
}

}  // namespace tandem::launcher
