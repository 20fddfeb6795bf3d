// Clean-up of Fast DDS shared-memory files left by processes that were killed (SIGKILL gives them no chance to
// remove their segments, port files, locks and data-sharing pools; `fastdds shm clean` leaves data-sharing
// pools behind). Used by the launcher after a killed child and at its end.
#pragma once

#include <ctime>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace tandem::runtime {

/// Names in /dev/shm of Fast DDS files (fastrtps_*, sem.fastrtps_*, fast_datasharing_*).
std::set<std::string> fastdds_shm_files();

/// The /dev/shm names this process has mapped or open now.
std::set<std::string> shm_used_by_self();

/// Removes the Fast DDS files in /dev/shm that were last modified at or after `since` (and at least 2 s ago: a
/// younger one may be being created) and that no live process has mapped or open (checked in /proc/*/maps and
/// /proc/*/fd). Files of other runs that started earlier are left alone. Port files (fastrtps_port<N>, its lock
/// and semaphore) would be reopened by a new participant that gets the same participant id, so they are removed
/// only with domain >= 0 and only in that domain's port range: call it so only when none of the domain's processes
/// can start any more (the end of a run); during a run, clean_free_ports removes those of ids no one holds. Segments and data-sharing pools are unique to a participant and a
/// writer, and are removed with any domain. With ignore_self, what this process has open does not count: at the
/// end of a run the launcher (or the soak) still holds the port files of the peers it sent to, which are dead by
/// then and would otherwise stay. Returns how many were removed.
int clean_stale_shm(std::time_t since, int domain = -1, bool ignore_self = false);

/// During a run: removes the Fast DDS files of this run (as clean_stale_shm) only once no live process has had them
/// mapped or open for quiet_s, seen at every sweep in between. Why not at once: Fast DDS 2.9's shared-memory
/// listener that pops a buffer descriptor naming a segment that no longer exists retries it for ever (the
/// descriptor stays at the head of its port; soak finding 50: 8000 failed shm_open a second, the port deaf for
/// good). A killed sender's descriptors can still wait in the port of a listener that is stopped or starved
/// (a stalled process, a busy core: the domain's shared multicast port is read by every participant), and
/// removing the sender's segment 2 s after the kill, as the launcher did, could wedge such a listener for good
/// (docs/soak.md, finding 71; whether it caused the wear-out of findings 59 and 69 is not shown). quiet_s is far
/// above any stall the soak injects; segments of killed processes thus live about a minute more (a few hundred KiB
/// each).
class ShmSweeper {
 public:
  static constexpr double kQuietS = 60.0;
  static constexpr std::time_t kEveryS = 5;  ///< between sweeps while files wait (see due())
  /// `only`: a name prefix the files must have (tests; empty: every Fast DDS file).
  ShmSweeper(std::time_t since, int domain, double quiet_s = kQuietS, std::string only = {});
  /// One pass at `now`: files unused now are noted, and those unused at every pass since quiet_s ago removed.
  /// Returns how many were removed.
  int sweep(std::time_t now);
  /// Files wait for their quiet time and the last sweep is kEveryS old.
  bool due(std::time_t now) const;
  size_t waiting() const { return unused_since_.size(); }

 private:
  std::time_t since_;
  int domain_;
  double quiet_s_;
  std::string only_;
  std::time_t last_ = 0;
  std::map<std::string, std::time_t> unused_since_;
};

/// The shared-memory port numbers of participant `id` in `domain` (its metatraffic and user unicast ports,
/// 7400 + 250 domain + 10 + 2 id and + 11: the RTPS port mapping).
std::pair<int, int> participant_ports(int domain, int id);

/// True if a port file (fastrtps_port<N>, its _el lock or its semaphore) of participant `id` in `domain` exists.
bool participant_port_files_exist(int domain, int id);

/// During a run: removes the port files of the participant ids in `free_ids` (ids no running process of the
/// caller was given) that no live process has mapped or open. A killed process leaves its port files behind, and
/// a newcomer given the same id opened those old files: after about a thousand kills in an hour, newcomers were
/// heard by nobody and modules could no longer start (soak finding 59). Only the caller hands these ids out, and it
/// does not while this runs, so no process is opening them meanwhile. Returns how many files were removed.
int clean_free_ports(int domain, const std::vector<int>& free_ids);

}  // namespace tandem::runtime
