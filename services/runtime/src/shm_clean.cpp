#include "tandem/runtime/shm_clean.hpp"

#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <utility>

namespace tandem::runtime {
namespace {

bool is_fastdds(const std::string& n) {
  return n.rfind("fastrtps_", 0) == 0 || n.rfind("sem.fastrtps_", 0) == 0 || n.rfind("fast_datasharing_", 0) == 0;
}

const std::string kPrefix = "/dev/shm/";

/// The /dev/shm names the process at /proc/<base> has mapped or open.
void used_by(const std::string& base, std::set<std::string>& used) {
  const std::string& prefix = kPrefix;
  {
    std::ifstream maps(base + "/maps");
    std::string line;
    while (std::getline(maps, line)) {
      const auto at = line.find(prefix);
      if (at == std::string::npos) continue;
      std::string name = line.substr(at + prefix.size());
      const auto del = name.find(" (deleted)");
      if (del != std::string::npos) name.erase(del);
      used.insert(name);
    }
    if (DIR* fds = ::opendir((base + "/fd").c_str())) {
      while (dirent* f = ::readdir(fds)) {
        if (f->d_name[0] == '.') continue;
        char buf[4096];
        const ssize_t n = ::readlink((base + "/fd/" + f->d_name).c_str(), buf, sizeof buf - 1);
        if (n <= 0) continue;
        buf[n] = '\0';
        if (std::strncmp(buf, prefix.c_str(), prefix.size()) == 0) used.insert(buf + prefix.size());
      }
      ::closedir(fds);
    }
  }
}

/// Every /dev/shm name some live process has mapped or open (but this one, with skip_self).
std::set<std::string> in_use(bool skip_self) {
  std::set<std::string> used;
  DIR* proc = ::opendir("/proc");
  if (proc == nullptr) return used;
  const std::string self = std::to_string(::getpid());
  while (dirent* e = ::readdir(proc)) {
    if (!std::isdigit(static_cast<unsigned char>(e->d_name[0]))) continue;
    if (skip_self && self == e->d_name) continue;
    used_by(std::string("/proc/") + e->d_name, used);
  }
  ::closedir(proc);
  return used;
}

}  // namespace

std::set<std::string> shm_used_by_self() {
  std::set<std::string> used;
  used_by("/proc/self", used);
  return used;
}

std::set<std::string> fastdds_shm_files() {
  std::set<std::string> out;
  if (DIR* d = ::opendir("/dev/shm")) {
    while (dirent* e = ::readdir(d)) {
      if (is_fastdds(e->d_name)) out.insert(e->d_name);
    }
    ::closedir(d);
  }
  // Secured processes' data-sharing segments, in this user's private directory (dds::private_shm_dir).
  const std::string sub = "tandem-" + std::to_string(::getuid());
  if (DIR* d = ::opendir((kPrefix + sub).c_str())) {
    while (dirent* e = ::readdir(d)) {
      if (is_fastdds(e->d_name)) out.insert(sub + "/" + e->d_name);
    }
    ::closedir(d);
  }
  return out;
}

namespace {
/// The port number of a port file ("fastrtps_port7411", "..._el", "sem.fastrtps_port7411_mutex"), -1 if none.
int port_of(const std::string& name) {
  const auto at = name.find("fastrtps_port");
  if (at == std::string::npos) return -1;
  return std::atoi(name.c_str() + at + 13);
}
}  // namespace

namespace {
/// One pass over the Fast DDS files of this run (see clean_stale_shm). With `unused_since`, a file is removed
/// only once it has been seen unused at every pass for `quiet_s`; the map is kept up to date.
int sweep_files(std::time_t since, int domain, bool ignore_self, std::time_t now,
                std::map<std::string, std::time_t>* unused_since, double quiet_s, const std::string& only) {
  const std::set<std::string> files = fastdds_shm_files();
  if (unused_since != nullptr) {
    for (auto it = unused_since->begin(); it != unused_since->end();) {  // gone meanwhile
      it = files.count(it->first) == 0 ? unused_since->erase(it) : std::next(it);
    }
  }
  if (files.empty()) return 0;
  const std::set<std::string> used = in_use(ignore_self);
  int removed = 0;
  for (const auto& name : files) {
    if (name.rfind(only, 0) != 0) continue;
    if (used.count(name) != 0) {
      if (unused_since != nullptr) unused_since->erase(name);
      continue;
    }
    // Port files are reused by the next participant that gets the same participant id: only the domain's own
    // (RTPS port mapping: 7400 + 250 * domain + offset), and only when asked for.
    const int port = port_of(name);
    if (port >= 0 && (domain < 0 || port < 7400 + 250 * domain || port >= 7400 + 250 * (domain + 1))) continue;
    const std::string path = "/dev/shm/" + name;
    struct stat st {};
    // A file younger than 2 s may belong to a process that is creating it right now (not yet mapped).
    if (::stat(path.c_str(), &st) != 0 || st.st_mtime < since || st.st_mtime > now - 2) continue;
    if (unused_since != nullptr) {
      const auto [at, fresh] = unused_since->emplace(name, now);
      if (fresh || static_cast<double>(now - at->second) < quiet_s) continue;
      unused_since->erase(at);
    }
    if (::unlink(path.c_str()) == 0) ++removed;
  }
  return removed;
}
}  // namespace

int clean_stale_shm(std::time_t since, int domain, bool ignore_self) {
  return sweep_files(since, domain, ignore_self, std::time(nullptr), nullptr, 0.0, {});
}

ShmSweeper::ShmSweeper(std::time_t since, int domain, double quiet_s, std::string only)
    : since_(since), domain_(domain), quiet_s_(quiet_s), only_(std::move(only)) {}

int ShmSweeper::sweep(std::time_t now) {
  last_ = now;
  return sweep_files(since_, domain_, false, now, &unused_since_, quiet_s_, only_);
}

bool ShmSweeper::due(std::time_t now) const { return !unused_since_.empty() && now - last_ >= kEveryS; }

std::pair<int, int> participant_ports(int domain, int id) {
  const int meta = 7400 + 250 * domain + 10 + 2 * id;
  return {meta, meta + 1};
}

namespace {
std::vector<std::string> port_file_names(int port) {
  const std::string p = std::to_string(port);
  return {"fastrtps_port" + p, "fastrtps_port" + p + "_el", "sem.fastrtps_port" + p + "_mutex"};
}
}  // namespace

bool participant_port_files_exist(int domain, int id) {
  const auto [meta, user] = participant_ports(domain, id);
  for (int port : {meta, user}) {
    for (const auto& n : port_file_names(port)) {
      struct stat st {};
      if (::stat((kPrefix + n).c_str(), &st) == 0) return true;
    }
  }
  return false;
}

int clean_free_ports(int domain, const std::vector<int>& free_ids) {
  if (domain < 0 || free_ids.empty()) return 0;
  const std::set<std::string> files = fastdds_shm_files();
  std::vector<std::string> candidates;
  for (int id : free_ids) {
    const auto [meta, user] = participant_ports(domain, id);
    for (int port : {meta, user}) {
      for (const auto& n : port_file_names(port)) {
        if (files.count(n) != 0) candidates.push_back(n);
      }
    }
  }
  if (candidates.empty()) return 0;
  const std::set<std::string> used = in_use(false);
  int removed = 0;
  for (const auto& n : candidates) {
    if (used.count(n) == 0 && ::unlink((kPrefix + n).c_str()) == 0) ++removed;
  }
  return removed;
}

}  // namespace tandem::runtime
