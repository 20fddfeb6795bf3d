#!/usr/bin/env bash
# Cost of DDS-Security in real time (docs/benchmarks.md, "Security"): N basic modules in `timing: realtime`,
# each configuration run without and with `security:` (keys by `tandem keys`: authentication, access control,
# AES-GCM encryption of discovery and data), alternately, R times, in the same session. Per run it prints late
# arm-ticks (%), sample->command latency p50/p99 (mean of the modules' p50, worst p99), CPU per module of the
# role processes (from /proc over 3 s of steady state) and the start-up time (launcher start to every world's
# first tick). Simple discovery in both (the Discovery Server has no identity: security refuses it).
#
# Usage: bash bench/security.sh [N ...]      default: 1 2
#   env: REPS (default 3), SECONDS_RUN (scenario duration, default 10), DOMAIN_BASE (default 130),
#        PRIO (realtime_priority, default 20)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/bin
[ -x "$bin/tandem" ] || { echo "security.sh: build first (bash scripts/build.sh)" >&2; exit 2; }
ns=("$@")
[ ${#ns[@]} -gt 0 ] || ns=(1 2)
for n in "${ns[@]}"; do
  [[ "$n" =~ ^[0-9]+$ ]] && [ "$n" -ge 1 ] && [ "$n" -le 16 ] || { echo "security.sh: N must be an integer in [1, 16], got '$n'" >&2; exit 2; }
done
reps="${REPS:-3}"
dur="${SECONDS_RUN:-10}"
prio="${PRIO:-20}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
. bench/lib.sh
echo "machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), kernel $(uname -r)"
echo "command: bash bench/security.sh ${ns[*]}  (REPS=$reps, duration ${dur} s, realtime_priority $prio, commit $(git rev-parse --short HEAD 2>/dev/null || echo '?'))"
sed "s/^  duration: .*/  duration: $dur/" config/scenarios/paper.yaml > "$work/scenario.yaml"
printf "%-3s %-7s %-7s %-7s %-7s %-8s %-8s %-8s\n" N security late% p50_us p99_us cpu/mod start_s result
idx=0
for n in "${ns[@]}"; do
  for rep in $(seq 1 "$reps"); do
    for sec in no yes; do
      domain=$(( ${DOMAIN_BASE:-130} + idx % 20 ))
      idx=$((idx + 1))
      dep="$work/sec$n.yaml"
      {
        echo "name: security$n"
        echo "domain_id: $domain"
        echo "timing: realtime"
        echo "realtime_priority: $prio"
        echo "timeout: 60"
        [ "$sec" = yes ] && printf "security:\n  keys: keys\n"
        echo "modules:"
        for i in $(seq 1 "$n"); do echo "  - {name: m$i, scenario: scenario.yaml, case: SOSM}"; done
      } > "$dep"
      [ "$sec" = yes ] && { "$bin/tandem" keys "$dep" > /dev/null || { echo "security.sh: tandem keys failed" >&2; exit 1; }; }
      log="$work/up.log"
      sum="$work/sum.txt"
      rm -f "$sum"
      start=$(date +%s.%N)
      "$bin/tandem" up "$dep" --summary "$sum" > "$log" 2>&1 &
      up=$!
      first=""
      while kill -0 "$up" 2>/dev/null; do
        c=$(grep -c "first tick at wall" "$log" || true)
        if [ "$c" -ge "$n" ]; then first=1; break; fi
        sleep 0.05
      done
      cpu=nan
      startup=$(startup_s "$log" "$start")
      if [ -n "$first" ]; then
        sleep 1
        pids=$( (pgrep -P "$up" -f "tandem-(world|robot|supervisor)" || true) | tr '\n' ' ')
        # A process gone meanwhile is left out (cpu_snap skips it and never fails under set -e).
        # shellcheck disable=SC2086
        cpu_snap $pids > "$work/t0"; w0=$(date +%s.%N)
        sleep 3
        # shellcheck disable=SC2086
        cpu_snap $pids > "$work/t1"; w1=$(date +%s.%N)
        cpu=$(cpu_cores "$work/t0" "$work/t1" "$w0" "$w1" "$n" "")
      fi
      rc=0; wait "$up" || rc=$?
      read -r late ticks p50 p99 _slips < <(summary_figures "$sum")
      pct=$(late_pct "$late" "$ticks")
      result=$([ "$rc" -eq 0 ] && echo PASS || echo "FAIL($rc)")
      # Why a run failed, in a line: the first process that exited with an error, or the launcher's own error.
      [ "$rc" -eq 0 ] || echo "    $(grep -m1 'exited with code\|peers not found\|tandem up: ' "$log" | cut -c1-150)"
      printf "%-3s %-7s %-7s %-7s %-7s %-8s %-8s %-8s\n" "$n" "$sec" "$pct" "$p50" "$p99" "$cpu" "$startup" "$result"
      sleep 1
    done
  done
done
