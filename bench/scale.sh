#!/usr/bin/env bash
# Real-time scale benchmark: N basic modules (world, supervisor, two robots each) in `timing: realtime`,
# with a bare 1 kHz timer loop (bench/timer_loop.cpp) running beside them in the same run. Per N it prints
# late arm-ticks (%), sample->command latency p50/p99 (mean of the modules' p50, worst p99), CPU per module
# in steady state (from /proc, all role processes, over a window after every world has ticked), RSS per
# process, start-up time until every world's first tick, slips, dropped objects, pauses for load (count and
# module-seconds paused: an overloaded module holds its object and brakes, docs/failure-model.md), and the timer
# loop's late fraction (ticks > 0.5 ms late). Beside them, in the same run: `tandem up --check`'s calibrated
# estimate of the CPU per module (and its error against the measured figure), and the bare layout's floor
# (bench/floor.cpp: the same processes per module, futex wake-ups, plant- and law-sized work, no DDS), with the
# runtime's CPU per module as a ratio to it (docs/benchmarks.md, "Capacity" and "Floor").
#
# Usage: bash bench/scale.sh [N ...]        default: 1 2 4 8 16
#   env: SECONDS_RUN (scenario duration, default 8), STANDBY (hot standby robots per arm, default 0: the estimate
#        then counts them, and the CPU per module includes them), DOMAIN_BASE (default 170), PRIO (realtime_priority,
#        default 20), TRANSPORT (shm|udp, default shm), DISCOVERY (simple|server, default server: the launcher
#        starts a Fast DDS Discovery Server), KEEP (a folder to keep the logs in)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/bin
[ -x "$bin/tandem" ] && [ -x "$bin/tandem_bench_timer" ] && [ -x "$bin/tandem_bench_floor" ] || { echo "scale.sh: build first (bash scripts/build.sh)" >&2; exit 2; }
ns=("$@")
[ ${#ns[@]} -gt 0 ] || ns=(1 2 4 8 16)
for n in "${ns[@]}"; do
  [[ "$n" =~ ^[0-9]+$ ]] && [ "$n" -ge 1 ] && [ "$n" -le 64 ] || { echo "scale.sh: N must be an integer in [1, 64], got '$n'" >&2; exit 2; }
done
dur="${SECONDS_RUN:-8}"
prio="${PRIO:-20}"
transport="${TRANSPORT:-shm}"
discovery="${DISCOVERY:-server}"
standby="${STANDBY:-0}"
[[ "$standby" =~ ^[0-3]$ ]] || { echo "scale.sh: STANDBY must be 0-3, got '$standby'" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
. bench/lib.sh
echo "machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), kernel $(uname -r)"
echo "command: bash bench/scale.sh ${ns[*]}  (duration ${dur} s, standby $standby, realtime_priority $prio, transport $transport, discovery $discovery, commit $(git rev-parse --short HEAD 2>/dev/null || echo '?'))"
sed "s/^  duration: .*/  duration: $dur/" config/scenarios/paper.yaml > "$work/scenario.yaml"
printf "%-4s %-8s %-8s %-8s %-8s %-8s %-8s %-6s %-6s %-13s %-7s %-8s %-8s %-8s %-7s %-10s %s\n" N late% p50_us p99_us cpu/mod rss_MB start_s slips drops "paused(n/s)" timer% est/mod est_err% floor/mod ratio result wake_us
idx=0
for n in "${ns[@]}"; do
  domain=$(( ${DOMAIN_BASE:-170} + idx ))
  idx=$((idx + 1))
  dep="$work/scale$n.yaml"
  {
    echo "name: scale$n"
    echo "domain_id: $domain"
    echo "transport: $transport"
    echo "discovery: $discovery"
    echo "timing: realtime"
    echo "realtime_priority: $prio"
    echo "timeout: 60"
    echo "modules:"
    for i in $(seq 1 "$n"); do
      echo "  - {name: m$i, scenario: scenario.yaml, case: SOSM, standby: $standby}"
    done
  } > "$dep"
  # The calibrated estimate, before the run (tandem up --check: well under a second).
  # Per module with its standbys: per module + 2 arms x STANDBY x per standby robot.
  check=$("$bin/tandem" up "$dep" --check)
  wake=$(printf '%s\n' "$check" | sed -n 's/.*wake-up \([0-9.]*\) us.*/\1/p' | head -1)
  est=$(printf '%s\n' "$check" | sed -n 's/.*(\([0-9.]*\) per module, \([0-9.]*\) per standby robot.*/\1 \2/p' | head -1 |
        awk -v s="$standby" 'NF == 2 {printf "%.3f", $1 + 2 * s * $2}')
  log="$work/up$n.log"
  : > "$log"
  start=$(date +%s.%N)
  "$bin/tandem" up "$dep" --summary "$work/sum$n.txt" > "$log" 2>&1 &
  up=$!
  tfifo=()
  [ "$prio" -gt 0 ] && tfifo=(--fifo "$prio")
  "$bin/tandem_bench_timer" --seconds "$((dur + 30))" "${tfifo[@]}" > "$work/timer$n.txt" &
  timer=$!
  # Wait for every world's first tick (or the launcher's end).
  first=""
  while kill -0 "$up" 2>/dev/null; do
    c=$(grep -c "first tick at wall" "$log" || true)
    if [ "$c" -ge "$n" ]; then first=$(date +%s.%N); break; fi
    sleep 0.1
  done
  cpu="nan"; rss="nan"
  if [ -n "$first" ]; then
    sleep 1
    # The role processes (the discovery server is not one of them), counted only if alive at both samples.
    pids=$( (pgrep -P "$up" -f "tandem-(world|robot|supervisor)" || true) | tr '\n' ' ')
    # shellcheck disable=SC2086
    cpu_snap $pids > "$work/t0"; w0=$(date +%s.%N)
    sleep 3
    # shellcheck disable=SC2086
    cpu_snap $pids > "$work/t1"; w1=$(date +%s.%N)
    rss=$(for p in $pids; do awk '/VmRSS/ {print $2}' /proc/$p/status 2>/dev/null; done | awk '{s += $1; c++} END {if (c) printf "%.1f", s / c / 1024; else print "nan"}')
    cpu=$(cpu_cores "$work/t0" "$work/t1" "$w0" "$w1" "$n" "")
  fi
  rc=0; wait "$up" || rc=$?
  kill "$timer" 2>/dev/null || true; wait "$timer" 2>/dev/null || true
  # The timer loop was cut short: run a fresh one only if it printed nothing.
  sum="$work/sum$n.txt"
  startup=$(startup_s "$log" "$start")
  read -r late ticks p50 p99 slips drops pauses paused_s < <(awk -F= -v n="$n" '
    /^m[0-9]+\.late_commands=/ {late += $2}
    /^m[0-9]+\.ticks=/ {ticks += $2}
    /^m[0-9]+\.latency_p50_us=/ {p50 += $2; c50++}
    /^m[0-9]+\.latency_p99_us=/ {if ($2 > p99) p99 = $2}
    /^m[0-9]+\.slip_events=/ {slips += $2}
    /^m[0-9]+\.object_final1=/ {if ($2 < 0.7) drops++}
    /^m[0-9]+\.load_pauses=/ {pauses += $2}
    /^m[0-9]+\.load_paused_ticks=/ {paused += $2}
    END {printf "%d %d %.0f %.0f %d %d %d %.1f\n", late, ticks, c50 ? p50 / c50 : 0, p99, slips, drops, pauses, paused / 1000}' "$sum" 2>/dev/null || echo "0 0 0 0 0 0 0 0")
  pct=$(late_pct "$late" "$ticks")
  tl=$(sed -n 's/^timer_late_fraction=//p' "$work/timer$n.txt" 2>/dev/null | awk '{printf "%.2f", 100 * $1}')
  result=$([ "$rc" -eq 0 ] && echo PASS || echo "FAIL($rc)")
  # The floor with the same number of modules, at the same priority, right after.
  ffifo=(); [ "$prio" -gt 0 ] && ffifo=(--fifo "$prio")
  floor=$("$bin/tandem_bench_floor" --modules "$n" --seconds 4 --robot-us "${FLOOR_ROBOT_US:-1}" --world-us "${FLOOR_WORLD_US:-45}" "${ffifo[@]}" | sed -n 's/.*cpu_per_module=\([0-9.]*\).*/\1/p')
  err=$(awk -v e="${est:-nan}" -v c="$cpu" 'BEGIN {if (c + 0 > 0 && e != "") printf "%+.0f", 100 * (e - c) / c; else print "nan"}')
  ratio=$(awk -v f="${floor:-0}" -v c="$cpu" 'BEGIN {if (f + 0 > 0 && c + 0 > 0) printf "%.2f", c / f; else print "nan"}')
  printf "%-4s %-8s %-8s %-8s %-8s %-8s %-8s %-6s %-6s %-13s %-7s %-8s %-8s %-8s %-7s %-10s %s\n" "$n" "$pct" "$p50" "$p99" "$cpu" "$rss" "$startup" "$slips" "$drops" "$pauses/$paused_s" "${tl:-nan}" "${est:-nan}" "$err" "${floor:-nan}" "$ratio" "$result" "${wake:-nan}"
  if [ -n "${KEEP:-}" ]; then mkdir -p "$KEEP"; cp "$log" "$sum" "$work/timer$n.txt" "$KEEP/" 2>/dev/null || true; fi
  sleep 1
done
