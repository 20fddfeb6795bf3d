#!/usr/bin/env bash
# Installs missing packages, then configures (once) and builds incrementally with at most 2 jobs.
# Usage: scripts/build.sh [preset] [--tests]   (preset: default | asan | tsan; see CMakePresets.json; --tests: also
# install what the test suite needs, see scripts/install-deps.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
preset=default
deps=()
for a in "$@"; do
  if [ "$a" = "--tests" ]; then deps+=(--tests); else preset="$a"; fi
done
bash scripts/install-deps.sh "${deps[@]}"
dir=build
[ "$preset" = default ] || dir="build-$preset"
if [ ! -f "$dir/CMakeCache.txt" ]; then
  cmake --preset "$preset" >/dev/null
fi
cmake --build --preset "$preset" -j 2
