#!/usr/bin/env bash
# Cost of the live view (docs/benchmarks.md, "Live view"): N basic modules in `timing: realtime`, each run without
# and with `tandem up --view-port 0` plus two clients kept open for the run (tests/tools/view/bench_clients.mjs: one
# as the page, on the viewer's JSON channels, and one as Foxglove Studio on every arm's sensors at full rate),
# alternately, R times, in the same session. Per run: late arm-ticks (%), sample->command latency p50/p99, CPU per
# module of the role processes, the viewer's CPU (from /proc over 3 s of steady state) and the messages the two
# clients got. A bare reference comes first: the same N modules with no viewer (the "no" rows).
#
# Usage: bash bench/view.sh [N ...]      default: 1 4 8
#   env: CLIENTS=stalled: instead of the two live clients, one Foxglove client that subscribes to every channel and
#        then reads nothing for the run (tests/tools/view/foxglove_client.mjs --stall): the "yes" rows are then the
#        deployment beside a viewer whose only client never reads; the columns "client" and "rss_kB+" then say
#        whether it stalled to the end and the viewer's RSS growth [kB] from the client's start to just before it
#        closes (SECONDS_RUN of 8 or more).
#        REPS (default 3), SECONDS_RUN (scenario duration, default 10), DOMAIN_BASE (default 170),
#        PRIO (realtime_priority, default 20), NODE_DIR (where bench_clients.mjs and its ws package are; default
#        build/tests/record-work/node, which the test suite fills)
set -euo pipefail
cd "$(dirname "$0")/.."
. bench/lib.sh
bin=build/bin
[ -x "$bin/tandem" ] || { echo "view.sh: build first (bash scripts/build.sh)" >&2; exit 2; }
node_dir="${NODE_DIR:-build/tests/record-work/node}"
[ -d "$node_dir/node_modules/ws" ] || { echo "view.sh: no ws package in $node_dir (run the view test once: ctest -R view:)" >&2; exit 2; }
cp tests/tools/view/bench_clients.mjs tests/tools/view/foxglove_client.mjs "$node_dir/"
mode="${CLIENTS:-live}"
[ "$mode" != stalled ] || [ "${SECONDS_RUN:-10}" -ge 8 ] || { echo "view.sh: CLIENTS=stalled needs SECONDS_RUN >= 8" >&2; exit 2; }
[ "$mode" = live ] || [ "$mode" = stalled ] || { echo "view.sh: CLIENTS must be live or stalled, got '$mode'" >&2; exit 2; }
ns=("$@")
[ ${#ns[@]} -gt 0 ] || ns=(1 4 8)
for n in "${ns[@]}"; do
  [[ "$n" =~ ^[0-9]+$ ]] && [ "$n" -ge 1 ] && [ "$n" -le 16 ] || { echo "view.sh: N must be an integer in [1, 16], got '$n'" >&2; exit 2; }
done
reps="${REPS:-3}"
dur="${SECONDS_RUN:-10}"
prio="${PRIO:-20}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), kernel $(uname -r)"
echo "command: bash bench/view.sh ${ns[*]}  (CLIENTS=$mode, REPS=$reps, duration ${dur} s, realtime_priority $prio, commit $(git rev-parse --short HEAD 2>/dev/null || echo '?'))"
sed "s/^  duration: .*/  duration: $dur/" config/scenarios/paper.yaml > "$work/scenario.yaml"
if [ "$mode" = stalled ]; then
  printf "%-3s %-5s %-7s %-7s %-7s %-8s %-9s %-10s %-10s %-6s %-8s\n" N view late% p50_us p99_us cpu/mod view_cpu client rss_kB+ slips result
else
  printf "%-3s %-5s %-7s %-7s %-7s %-8s %-9s %-10s %-10s %-6s %-8s\n" N view late% p50_us p99_us cpu/mod view_cpu page_msgs fox_msgs slips result
fi
idx=0
for n in "${ns[@]}"; do
  for rep in $(seq 1 "$reps"); do
    for view in no yes; do
      domain=$(( ${DOMAIN_BASE:-170} + idx % 20 ))
      idx=$((idx + 1))
      dep="$work/view$n.yaml"
      {
        echo "name: view$n"
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
      rm -f "$sum"
      args=()
      [ "$view" = yes ] && args=(--view-port 0)
      "$bin/tandem" up "$dep" --summary "$sum" "${args[@]}" > "$log" 2>&1 &
      up=$!
      first=""
      while kill -0 "$up" 2>/dev/null; do
        c=$(grep -c "first tick at wall" "$log" || true)
        if [ "$c" -ge "$n" ]; then first=1; break; fi
        sleep 0.1
      done
      cpu=nan; vcpu=-; pmsg=-; fmsg=-
      if [ -n "$first" ]; then
        if [ "$view" = yes ]; then
          port=$(sed -n 's/^tandem view: .* at http:\/\/127\.0\.0\.1:\([0-9]*\)\/.*/\1/p' "$log" | head -1)
          if [ "$mode" = stalled ]; then
            vpid0=$(pgrep -P "$up" -f "tandem view" || true)
            rss0=$(awk '/^VmRSS/ {print $2}' "/proc/$vpid0/status" 2>/dev/null || echo 0)
            node "$node_dir/foxglove_client.mjs" "ws://127.0.0.1:$port" tandem/arm_sensors/m1/left 1 --stall $(( dur - 2 )) \
              > "$work/clients.log" 2>&1 &
          else
            node "$node_dir/bench_clients.mjs" "ws://127.0.0.1:$port" $(( dur - 2 )) > "$work/clients.log" 2>&1 &
          fi
          clients=$!
        fi
        sleep 1
        pids=$( (pgrep -P "$up" -f "tandem-(world|robot|supervisor)" || true) | tr '\n' ' ')
        vpid=$(pgrep -P "$up" -f "tandem view" || true)
        cpu_snap $pids $vpid > "$work/t0"; w0=$(date +%s.%N)
        sleep 3
        cpu_snap $pids $vpid > "$work/t1"; w1=$(date +%s.%N)
        cpu=$(cpu_cores "$work/t0" "$work/t1" "$w0" "$w1" "$n" "$pids")
        [ -n "$vpid" ] && vcpu=$(cpu_cores "$work/t0" "$work/t1" "$w0" "$w1" 1 "$vpid")
        if [ "$view" = yes ] && [ "$mode" = stalled ]; then
          # The viewer's RSS once the client has stalled for the run (read just before it closes), minus at its start.
          sleep $(( dur - 2 - 4 - 1 )) 2>/dev/null || true
          rss1=$(awk '/^VmRSS/ {print $2}' "/proc/$vpid/status" 2>/dev/null || echo 0)
          wait "$clients" || true
          grep -q "stalled" "$work/clients.log" && pmsg=stalled || pmsg="client-failed"
          fmsg=$(( rss1 - rss0 ))
        elif [ "$view" = yes ]; then
          wait "$clients" || true
          pmsg=$(awk '$1 == "page" {print $2}' "$work/clients.log"); fmsg=$(awk '$1 == "foxglove" {print $2}' "$work/clients.log")
        fi
      fi
      rc=0; wait "$up" || rc=$?
      read -r late ticks p50 p99 slips < <(summary_figures "$sum")
      pct=$(awk -v l="$late" -v t="$ticks" 'BEGIN {if (t > 0) printf "%.2f", 100 * l / (2 * t); else print "nan"}')
      result=$([ "$rc" -eq 0 ] && echo PASS || echo "FAIL($rc)")
      printf "%-3s %-5s %-7s %-7s %-7s %-8s %-9s %-10s %-10s %-6s %-8s\n" "$n" "$view" "$pct" "$p50" "$p99" "$cpu" "$vcpu" "${pmsg:--}" "${fmsg:--}" "$slips" "$result"
      sleep 1
    done
  done
done
