#!/usr/bin/env bash
# Cost of recording in real time (docs/benchmarks.md, "Recording"): N basic modules in `timing: realtime`, each
# configuration run without and with `tandem up --record` (the recorder: its own participant, every topic
# group), alternately, R times, in the same session. Per run it prints late arm-ticks (%), sample->command
# latency p50/p99 (mean of the modules' p50, worst p99), CPU per module of the role processes and the
# recorder's own CPU (from /proc over 3 s of steady state), ticks the recorder missed (gaps), and the file's
# size and rate.
#
# Usage: bash bench/record.sh [N ...]      default: 1 4
#   env: REPS (default 3), SECONDS_RUN (scenario duration, default 10), DOMAIN_BASE (default 150),
#        PRIO (realtime_priority, default 20)
set -euo pipefail
cd "$(dirname "$0")/.."
. bench/lib.sh
bin=build/bin
[ -x "$bin/tandem" ] || { echo "record.sh: build first (bash scripts/build.sh)" >&2; exit 2; }
ns=("$@")
[ ${#ns[@]} -gt 0 ] || ns=(1 4)
for n in "${ns[@]}"; do
  [[ "$n" =~ ^[0-9]+$ ]] && [ "$n" -ge 1 ] && [ "$n" -le 16 ] || { echo "record.sh: N must be an integer in [1, 16], got '$n'" >&2; exit 2; }
done
reps="${REPS:-3}"
dur="${SECONDS_RUN:-10}"
prio="${PRIO:-20}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), kernel $(uname -r)"
echo "command: bash bench/record.sh ${ns[*]}  (REPS=$reps, duration ${dur} s, realtime_priority $prio, commit $(git rev-parse --short HEAD 2>/dev/null || echo '?'))"
sed "s/^  duration: .*/  duration: $dur/" config/scenarios/paper.yaml > "$work/scenario.yaml"
printf "%-3s %-4s %-7s %-7s %-7s %-7s %-8s %-9s %-6s %-8s %-8s %-8s\n" N rec late% p50_us p99_us cpu/mod rec_cpu "gaps(t)" MB MB/s slips result
idx=0
for n in "${ns[@]}"; do
  for rep in $(seq 1 "$reps"); do
    for rec in no yes; do
      domain=$(( ${DOMAIN_BASE:-150} + idx % 20 ))
      idx=$((idx + 1))
      dep="$work/rec$n.yaml"
      {
        echo "name: record$n"
        echo "domain_id: $domain"
        echo "discovery: server"
        echo "timing: realtime"
        echo "realtime_priority: $prio"
        echo "timeout: 60"
        echo "modules:"
        for i in $(seq 1 "$n"); do echo "  - {name: m$i, scenario: scenario.yaml, case: SOSM}"; done
      } > "$dep"
      log="$work/up.log"
      sum="$work/sum.txt"
      rm -f "$sum" "$work/run.mcap"
      args=()
      [ "$rec" = yes ] && args=(--record "$work/run.mcap")
      "$bin/tandem" up "$dep" --summary "$sum" "${args[@]}" > "$log" 2>&1 &
      up=$!
      first=""
      while kill -0 "$up" 2>/dev/null; do
        c=$(grep -c "first tick at wall" "$log" || true)
        if [ "$c" -ge "$n" ]; then first=1; break; fi
        sleep 0.1
      done
      cpu=nan; rcpu=-
      if [ -n "$first" ]; then
        sleep 1
        pids=$( (pgrep -P "$up" -f "tandem-(world|robot|supervisor)" || true) | tr '\n' ' ')
        rpid=$(pgrep -P "$up" -f "tandem record" || true)
        cpu_snap $pids $rpid > "$work/t0"; w0=$(date +%s.%N)
        sleep 3
        cpu_snap $pids $rpid > "$work/t1"; w1=$(date +%s.%N)
        cpu=$(cpu_cores "$work/t0" "$work/t1" "$w0" "$w1" "$n" "$pids")
        [ -n "$rpid" ] && rcpu=$(cpu_cores "$work/t0" "$work/t1" "$w0" "$w1" 1 "$rpid")
      fi
      rc=0; wait "$up" || rc=$?
      read -r late ticks p50 p99 slips < <(summary_figures "$sum")
      pct=$(awk -v l="$late" -v t="$ticks" 'BEGIN {if (t > 0) printf "%.2f", 100 * l / (2 * t); else print "nan"}')
      gaps=-; mb=-; rate=-
      if [ "$rec" = yes ]; then
        gaps=$(sed -n 's/.* \([0-9]*\) tick(s) missed in \([0-9]*\) gap(s).*/\2(\1)/p' "$log" | head -1)
        bytes=$(stat -c %s "$work/run.mcap" 2>/dev/null || echo 0)
        mb=$(awk -v b="$bytes" 'BEGIN {printf "%.1f", b / 1048576}')
        rate=$(awk -v b="$bytes" -v d="$dur" 'BEGIN {printf "%.2f", b / 1048576 / d}')
      fi
      result=$([ "$rc" -eq 0 ] && echo PASS || echo "FAIL($rc)")
      printf "%-3s %-4s %-7s %-7s %-7s %-7s %-8s %-9s %-6s %-8s %-8s %-8s\n" "$n" "$rec" "$pct" "$p50" "$p99" "$cpu" "$rcpu" "${gaps:-?}" "$mb" "$rate" "$slips" "$result"
      sleep 1
    done
  done
done
