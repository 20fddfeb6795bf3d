// Clean-up of Fast DDS shared-memory files left by processes that were killed (SIGKILL gives them no chance to
// remove their segments, port files, locks and data-sharing pools; `fastdds shm clean` leaves data-sharing
// pools behind). Used by the launcher after a killed child and at its end.
#pragma once

#include <ctime>
#include <set>
#include <string>

namespace tandem::runtime {

/// Names in /dev/shm of Fast DDS files (fastrtps_*, sem.fastrtps_*, fast_datasharing_*).
std::set<std::string> fastdds_shm_files();

/// The /dev/shm names this process has mapped or open now.
std::set<std::string> shm_used_by_self();

/// Removes the Fast DDS files in /dev/shm that were last modified at or after `since` (and at least 2 s ago: a
/// younger one may be being created) and that no live process has mapped or open (checked in /proc/*/maps and
/// /proc/*/fd). Files of other runs that started earlier are left alone. Port files (fastrtps_port<N>, its lock
/// and semaphore) are reused by a new participant that gets the same participant id, so they are removed only
/// with domain >= 0 and only in that domain's port range: call it so only when none of the domain's processes
/// can start any more (the end of a run). Segments and data-sharing pools are unique to a participant and a
/// writer, and are removed with any domain. With ignore_self, what this process has open does not count: at the
/// end of a run the launcher (or the soak) still holds the port files of the peers it sent to, which are dead by
/// then and would otherwise stay. Returns how many were removed.
int clean_stale_shm(std::time_t since, int domain = -1, bool ignore_self = false);

}  // namespace tandem::runtime
