#!/usr/bin/env bash
# Failover benchmark: one module in real time with a hot standby per arm; the primary of the left arm is
# SIGKILLed N times (default 100) while the coordinator keeps the object moving back and forth. After each
# kill the standby takes over (a failover, measured by the world: last command of the dead primary -> first
# applied command of the standby), the launcher restarts the killed robot as the primary, and it takes the arm
# back (a takeover). Reports the failover-time distribution (p50, p99, max) and, over the 300 ticks after each
# switch, the worst end-effector tracking error and the lowest normal force, against h_sg.
# Usage: [TIMING=lockstep|realtime] [TRANSPORT=udp|shm] bench/failover.sh [kills] [domain]   (build first)
set -euo pipefail
cd "$(dirname "$0")/.."
kills="${1:-100}"
domain="${2:-$(( 150 + $$ % 50 ))}"
bin=build/bin
work=$(mktemp -d)
up=""
cleanup() {
  [ -n "$up" ] && kill "$up" 2>/dev/null && wait "$up" 2>/dev/null
  cp "$work/up.log" /tmp/failover-bench-up.log 2>/dev/null || true  # the launcher's log, for a look afterwards
  rm -rf "$work"
}
trap cleanup EXIT
period=1.0   # seconds after the takeover before the next kill: the restarted primary is back well within it
# UDP by default: over shared memory a SIGKILLed participant's port can stall its peers for about 2 s and keep a
# process restarted in its place from receiving (docs/failure-model.md). Lockstep by default: on 2 cores a
# real-time module with a standby per arm, its coordinator and launcher misses a quarter of its ticks over
# UDP, which is a load figure, not a failover one (TIMING=realtime runs it anyway).
transport="${TRANSPORT:-udp}"
timing="${TIMING:-lockstep}"
# Enough 2 s tasks to outlast the kills (a kill costs the period plus about a second for the command).
tasks=$(awk -v k="$kills" 'BEGIN { print int(k * 10) + 10 }')
echo "machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), kernel $(uname -r)"
echo "kills: $kills every ${period} s, domain $domain, $tasks tasks of 2 s, $timing timing over $transport"
{
  echo "name: failover-bench"
  echo "domain_id: $domain"
  echo "transport: $transport"
  echo "timing: $timing"
  echo "timeout: 10"
  echo "coordinator:"
  echo "  tasks:"
  for i in $(seq "$tasks"); do
    if [ $((i % 2)) -eq 1 ]; then to="[0.1, 0.8, 0.0]"; else to="[-0.1, 0.8, 0.0]"; fi
    echo "    - {name: t$i, segments: [{to: $to, duration: 2.0}]}"
  done
  echo "modules:"
  echo "  - {name: m1, scenario: $PWD/config/scenarios/paper.yaml, case: SOSM, standby: 1,"
  echo "     restart: always, restart_as: primary, restart_limit: 100, restart_window: 1, restart_backoff: 0.1}"
} > "$work/failover.yaml"

"$bin/tandem" up "$work/failover.yaml" --summary "$work/summary.txt" > "$work/up.log" 2>&1 &
up=$!
sleep 3
kill -0 "$up" 2>/dev/null || { cat "$work/up.log"; echo "tandem up did not start" >&2; exit 1; }
done_kills=0
for i in $(seq "$kills"); do
  kill -0 "$up" 2>/dev/null || { echo "tandem up ended after $done_kills kills (its tasks were done?)" >&2; break; }
  "$bin/tandem" kill "$work/failover.yaml" m1/left > /dev/null || echo "kill $i: not answered"
  done_kills=$i
  # Wait until the restarted primary has taken the arm back (a takeover), so that every kill hits a serving
  # primary with a warm standby behind it; then let it run a little.
  for _ in $(seq 100); do
    [ "$(grep -c 'takeover [0-9.]* ms after' "$work/up.log")" -ge "$i" ] && break
    sleep 0.1
  done
  sleep "$period"
  [ $((i % 10)) -eq 0 ] && echo "  $i/$kills kills" >&2
done
"$bin/tandem" down "$work/failover.yaml" > /dev/null 2>&1 || true
wait "$up" || true
up=""
grep -E "^m1: [0-9]+ ticks|^m1: real time|^coordinator: |^result" "$work/up.log" || true
h_sg=19.62   # eq. (16) for the paper's object (docs/results.md)
list() { sed -n "s/^m1.$1=//p" "$work/summary.txt" | tr ',' '\n'; }
paste <(list switch_gap_ms) <(list switch_failover) <(list switch_ep_max) <(list switch_hn_min) > "$work/switches.tsv"
awk '$2 == 1' "$work/switches.tsv" > "$work/fo.tsv"
awk '$2 == 0' "$work/switches.tsv" > "$work/to.tsv"
n=$(wc -l < "$work/fo.tsv")
echo "kills=$done_kills failovers=$n takeovers=$(wc -l < "$work/to.tsv")"
if [ "$n" -gt 0 ]; then
  cut -f1 "$work/fo.tsv" | sort -g > "$work/gaps"
  pick() { sed -n "$1p" "$work/gaps"; }
  i50=$(( (n + 1) / 2 )); i99=$(( (n * 99 + 99) / 100 )); [ "$i99" -gt "$n" ] && i99=$n
  echo "failover_p50_ms=$(pick $i50)"
  echo "failover_p99_ms=$(pick $i99)"
  echo "failover_max_ms=$(pick "$n")"
  echo "failover_worst_ep_m=$(cut -f3 "$work/fo.tsv" | sort -g | tail -1)"
  echo "failover_lowest_normal_N=$(cut -f4 "$work/fo.tsv" | sort -g | head -1)"
fi
if [ -s "$work/to.tsv" ]; then
  echo "takeover_worst_ep_m=$(cut -f3 "$work/to.tsv" | sort -g | tail -1)"
  echo "takeover_lowest_normal_N=$(cut -f4 "$work/to.tsv" | sort -g | head -1)"
fi
echo "h_sg_N=$h_sg"
echo "slip_events=$(sed -n 's/^m1.slip_events=//p' "$work/summary.txt")"
echo "contact_lost=$(sed -n 's/^m1.contact_lost=//p' "$work/summary.txt")"
echo "late_or_braking=$(sed -n 's/^m1.late_commands=//p' "$work/summary.txt") (real time: late arm-ticks; lockstep: brakings)"
echo "braked_arm_ticks=$(sed -n 's/^m1.braked_ticks=//p' "$work/summary.txt")"
