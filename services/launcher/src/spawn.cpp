#include "tandem/launcher/spawn.hpp"

#include "tandem/launcher/sched_group.hpp"

#include <sched.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>

extern char** environ;

namespace tandem::launcher {

pid_t spawn(const std::string& who, const std::string& exe, const std::vector<std::string>& args,
            const SpawnOptions& opt) {
  // Everything the child needs is built before fork: after fork only async-signal-safe calls.
  std::vector<char*> argv;
  argv.reserve(args.size() + 2);
  argv.push_back(const_cast<char*>(exe.c_str()));
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  std::vector<std::string> env_text;
  for (char** e = environ; *e != nullptr; ++e) {
    if (std::strncmp(*e, "TANDEM_PARTICIPANT_ID=", 22) != 0 && std::strncmp(*e, "TANDEM_IDENTITY=", 16) != 0 &&
        std::strncmp(*e, "TANDEM_RT_PRIORITY=", 19) != 0 && std::strncmp(*e, "TANDEM_CPU=", 11) != 0 &&
        (opt.discovery.empty() || std::strncmp(*e, "ROS_DISCOVERY_SERVER=", 21) != 0)) {
      env_text.emplace_back(*e);
    }
  }
  if (!opt.discovery.empty()) env_text.push_back("ROS_DISCOVERY_SERVER=" + opt.discovery);
  if (opt.participant_id >= 0) env_text.push_back("TANDEM_PARTICIPANT_ID=" + std::to_string(opt.participant_id));
  // DDS-Security: the child's identity (its slot's key; TANDEM_SECURITY_DIR is inherited from the parent).
  if (!opt.identity.empty()) env_text.push_back("TANDEM_IDENTITY=" + opt.identity);
  // Real time once active: the child starts at normal priority and raises itself when it turns active
  // (runtime::raise_to_realtime_from_env), so that its start-up never preempts the running modules.
  if (opt.rt_priority > 0) env_text.push_back("TANDEM_RT_PRIORITY=" + std::to_string(opt.rt_priority));
  if (opt.cpu >= 0) env_text.push_back("TANDEM_CPU=" + std::to_string(opt.cpu));
  std::vector<char*> envp;
  envp.reserve(env_text.size() + 1);
  for (auto& e : env_text) envp.push_back(e.data());
  envp.push_back(nullptr);
  const pid_t parent = ::getpid();
  errno = 0;
  const int nice_now = ::getpriority(PRIO_PROCESS, 0);
  const int inherited_nice = errno == 0 ? nice_now : 0;
  const pid_t pid = ::fork();
  if (pid < 0) {
    std::fprintf(stderr, "%s: cannot start %s: fork failed: %s\n", who.c_str(), exe.c_str(), std::strerror(errno));
    return -1;
  }
  if (pid != 0) return pid;
  ::signal(SIGINT, SIG_DFL);  // the parent's handlers must not be inherited
  ::signal(SIGTERM, SIG_DFL);
  ::prctl(PR_SET_PDEATHSIG, SIGTERM);  // never outlive the parent
  if (::getppid() != parent) ::_exit(127);
  // Its own session and autogroup at the niceness it inherited: otherwise every child shares the launcher's session
  // group, which the scheduler weighs as one process against another session's load (sched_group.hpp).
  if (opt.own_group) own_sched_group(inherited_nice);
  // Nothing of the parent's but stdin/out/err: Fast DDS opens its sockets without close-on-exec, and a child
  // that held the launcher's discovery and data ports would keep them bound after the launcher is gone.
  ::close_range(3, ~0U, 0);
  ::execve(exe.c_str(), argv.data(), envp.data());
  static const char msg[] = "tandem: cannot exec a role process\n";
  (void)!::write(2, msg, sizeof msg - 1);
  ::_exit(127);
}

bool own_group_for(const std::string& role, const std::vector<std::string>& args) {
  if (role != "world" && role != "robot") return true;
  for (size_t i = 0; i + 1 < args.size(); ++i) {
    if (args[i] == "--timing") return args[i + 1] == "realtime";
  }
  return false;  // the roles' default timing is lockstep
}

bool fifo_permitted(int priority, std::string& why) {
  sched_param sp{};
  sp.sched_priority = priority;
  if (::sched_setscheduler(0, SCHED_FIFO, &sp) != 0) {
    why = std::strerror(errno);
    return false;
  }
  sp.sched_priority = 0;
  (void)::sched_setscheduler(0, SCHED_OTHER, &sp);
  return true;
}

bool raise_service_priority(std::string& why, bool group) {
  // Linux keeps a niceness per thread: PRIO_PROCESS with 0 is the calling thread, and new threads inherit it.
  if (::setpriority(PRIO_PROCESS, 0, kServiceNice) != 0) {
    why = std::strerror(errno);
    return false;
  }
  // A session leader (`setsid tandem up ...`, or a launcher that `tandem soak` started) has an autogroup of its own:
  // rank it the same way. Never the group of a shell the process merely runs in, which the user's jobs share.
  if (group && leads_session()) (void)set_autogroup_nice(kServiceNice);
  return true;
}

std::string self_dir() {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) return ".";
  buf[n] = '\0';
  std::string p(buf);
  return p.substr(0, p.rfind('/'));
}

}  // namespace tandem::launcher
