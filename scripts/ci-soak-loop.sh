#!/usr/bin/env bash
# The CI soak test N times in a row (issue "no drops": it must pass 20 times in a row on this machine), stopping at
# the first failure, whose log is kept. Run after a build (bash scripts/build.sh default --tests).
# Usage: bash scripts/ci-soak-loop.sh [N]      (default 20; logs in ${LOG_DIR:-/tmp/ci-soak-loop})
set -uo pipefail
cd "$(dirname "$0")/../build" || { echo "ci-soak-loop: no build directory (bash scripts/build.sh default --tests)" >&2; exit 2; }
n=${1:-20}
[[ "$n" =~ ^[0-9]+$ ]] && [ "$n" -ge 1 ] || { echo "ci-soak-loop: N must be a positive integer, got '$n'" >&2; exit 2; }
logs=${LOG_DIR:-/tmp/ci-soak-loop}
mkdir -p "$logs"
echo "ci-soak-loop: $n runs of 'soak: a 75 s soak' on commit $(git rev-parse --short HEAD 2>/dev/null || echo '?'), logs in $logs"
for i in $(seq 1 "$n"); do
  s=$(date +%s)
  if ctest -R "soak: a 75 s soak" --output-on-failure > "$logs/run$i.log" 2>&1; then
    echo "run $i: PASS ($(( $(date +%s) - s )) s)"
  else
    echo "run $i: FAIL ($(( $(date +%s) - s )) s): $logs/run$i.log"
    exit 1
  fi
done
echo "ci-soak-loop: $n of $n passed"
