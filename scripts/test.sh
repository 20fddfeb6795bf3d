#!/usr/bin/env bash
# The tests: install what is missing, build incrementally, and run the whole ctest suite.
# Usage: scripts/test.sh [preset] [extra ctest args...]   (preset: default | asan)
set -euo pipefail
cd "$(dirname "$0")/.."
preset=default
if [ $# -gt 0 ] && [ "${1#-}" = "$1" ]; then preset="$1"; shift; fi
bash scripts/build.sh "$preset" --tests
dir=build
[ "$preset" = default ] || dir="build-$preset"
ctest --test-dir "$dir" --output-on-failure -j 2 "$@"
