#!/usr/bin/env bash
# ThreadSanitizer run: builds the tsan preset (unit tests, the role processes, the CLI and the distributed
# tests), then runs every unit test and one distributed test (its processes are tsan builds too, with their
# listener threads). Exit 1 if ThreadSanitizer reported anything; the reports are in build-tsan/tsan.*.
# Usage: scripts/tsan.sh ["distributed test name"]
set -euo pipefail
cd "$(dirname "$0")/.."
test_name=${1:-"lockstep over DDS gives the embedded simulation's numbers"}
bash scripts/install-deps.sh --tests
[ -f build-tsan/CMakeCache.txt ] || cmake --preset tsan >/dev/null
cmake --build build-tsan -j 2 --target tandem_unit_tests tandem_distributed_tests tandem tandem-world tandem-robot \
  tandem-supervisor tandem-coordinator
rm -f build-tsan/tsan.*
# Fast DDS itself is not instrumented: its internal locking is invisible to tsan, so reports whose every
# frame is inside libfastrtps are suppressed (scripts/tsan.supp, each entry with its reason).
# exitcode=0: a process with reports still exits as it would (the deployment runs to its end); the reports
# are counted from the log files below.
export TSAN_OPTIONS="log_path=$PWD/build-tsan/tsan suppressions=$PWD/scripts/tsan.supp second_deadlock_stack=1 exitcode=0"
rc=0
(cd build-tsan/tests && ./tandem_unit_tests) || rc=1
(cd build-tsan/tests && ./tandem_distributed_tests "$test_name") || rc=1
reports=$(find build-tsan -maxdepth 1 -name "tsan.*" | wc -l)  # ls would fail (set -e, pipefail) with none
echo "tsan: $reports report file(s)"
if [ "$reports" -gt 0 ]; then
  grep -h "^WARNING: ThreadSanitizer" build-tsan/tsan.* | sort | uniq -c
  exit 1
fi
exit "$rc"
