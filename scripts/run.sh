#!/usr/bin/env bash
# The main job: install what is missing, build incrementally, and run tandem.
# With no arguments it runs the default: the paper's simulation cases on one basic module.
# Usage: scripts/run.sh [tandem arguments...]    e.g. scripts/run.sh sim config/scenarios/paper.yaml
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh default
if [ $# -eq 0 ]; then
  set -- sim config/scenarios/paper.yaml
fi
exec ./build/services/cli/tandem "$@"
