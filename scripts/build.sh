#!/usr/bin/env bash
# Installs missing packages, then configures (once) and builds incrementally with at most 2 jobs.
# Usage: scripts/build.sh [preset]   (preset: default | asan; see CMakePresets.json)
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-default}"
bash scripts/install-deps.sh
dir=build
[ "$preset" = default ] || dir="build-$preset"
if [ ! -f "$dir/CMakeCache.txt" ]; then
  cmake --preset "$preset" >/dev/null
fi
cmake --build --preset "$preset" -j 2
