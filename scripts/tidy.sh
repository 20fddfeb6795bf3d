#!/usr/bin/env bash
# clang-tidy over the C++ files a change touches, with the repository's .clang-tidy.
# Usage: scripts/tidy.sh [BASE]   BASE: a commit to compare with (default: HEAD~1, the last commit's change).
# Needs build/compile_commands.json (scripts/build.sh writes it). Exit 1 if a gating finding (bugprone-*,
# performance-*, a compiler diagnostic) is in a changed file; the other findings are counted, not gating.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v clang-tidy >/dev/null || { SUDO=; [ "$(id -u)" = 0 ] || SUDO=sudo; $SUDO apt-get install -y -qq clang-tidy >/dev/null; }
[ -f build/compile_commands.json ] || { echo "tidy: build/compile_commands.json is missing; run scripts/build.sh first"; exit 2; }
base=${1:-HEAD~1}
if git rev-parse -q --verify "$base^{commit}" >/dev/null; then
  files=$(git diff --name-only --diff-filter=AM "$base" -- '*.cpp' | grep -E '^(services|tests|bench)/' || true)
else
  files=$(git show --name-only --pretty=format: HEAD -- '*.cpp' | grep -E '^(services|tests|bench)/' || true)
fi
[ -n "$files" ] || { echo "tidy: no C++ source changed since $base"; exit 0; }
n=$(echo "$files" | wc -l)
echo "tidy: $n changed file(s) since $base"
log=$(mktemp); trap 'rm -f "$log"' EXIT
# Two at a time (the machine has 2 cores); every file is checked even when one fails.
echo "$files" | xargs -P 2 -I{} sh -c 'clang-tidy -p build --quiet "{}" 2>/dev/null || true' > "$log"
here="$PWD/"
findings=$(grep -E "^${here}(services|tests|bench)/.*: (warning|error): " "$log" | sort -u || true)
gating=$(echo "$findings" | grep -E '\[(bugprone-|performance-|clang-diagnostic-)[^]]*\]$' || true)
if [ -n "$findings" ]; then
  echo "tidy: findings by check (changed files and their headers):"
  echo "$findings" | sed -E 's/.*\[([^]]*)\]$/\1/' | sort | uniq -c | sort -rn | sed 's/^/  /'
fi
if [ -n "$gating" ]; then
  echo "tidy: FAIL: gating findings:"
  echo "$gating" | sed "s|$here||"
  exit 1
fi
echo "tidy: PASS (no bugprone, performance or compiler finding in the changed files)"
