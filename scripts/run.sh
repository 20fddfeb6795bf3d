#!/usr/bin/env bash
# The main job: install what is missing, build incrementally, and run tandem.
# With no arguments it runs the default deployment, deploy/one-module.yaml: one basic module as four
# processes (world, supervisor, two robots) over Fast DDS, in lockstep.
# Usage: scripts/run.sh [tandem arguments...]    e.g. scripts/run.sh sim config/scenarios/paper.yaml
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh default
if [ $# -eq 0 ]; then
  set -- up deploy/one-module.yaml
fi
exec ./build/bin/tandem "$@"
