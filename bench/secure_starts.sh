#!/usr/bin/env bash
# Secured start-up, counted (docs/benchmarks.md, "Secured start-up"): R consecutive `tandem up` runs of a secured
# lockstep deployment of M basic modules (a short task), each with fresh processes. Per start it records whether
# the run passed, how many start-up repairs the launcher needed (modules restarted because a pair never
# authenticated: docs/security.md, "Start-up") and the wall time from launch to every world's first tick.
# Prints one line per start and a summary: starts, passed, starts that needed a repair, repairs, start-up time
# median and max. Exit 1 if any start failed.
#
# Usage: bash bench/secure_starts.sh [R] [M]      default: R=50, M=1
#   env: SECONDS_RUN (scenario duration, default 1), DOMAIN_BASE (default 150), TRANSPORT (shm | udp, default shm),
#        TIMING (lockstep | realtime, default lockstep)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/bin
[ -x "$bin/tandem" ] || { echo "secure_starts.sh: build first (bash scripts/build.sh)" >&2; exit 2; }
reps="${1:-50}"
mods="${2:-1}"
[[ "$reps" =~ ^[0-9]+$ ]] && [ "$reps" -ge 1 ] || { echo "secure_starts.sh: R must be a positive integer, got '$reps'" >&2; exit 2; }
[[ "$mods" =~ ^[0-9]+$ ]] && [ "$mods" -ge 1 ] && [ "$mods" -le 8 ] || { echo "secure_starts.sh: M must be an integer in [1, 8], got '$mods'" >&2; exit 2; }
transport="${TRANSPORT:-shm}"
[ "$transport" = shm ] || [ "$transport" = udp ] || { echo "secure_starts.sh: TRANSPORT must be shm or udp, got '$transport'" >&2; exit 2; }
timing="${TIMING:-lockstep}"
[ "$timing" = lockstep ] || [ "$timing" = realtime ] || { echo "secure_starts.sh: TIMING must be lockstep or realtime, got '$timing'" >&2; exit 2; }
dur="${SECONDS_RUN:-1}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), kernel $(uname -r)"
echo "command: bash bench/secure_starts.sh $reps $mods  (duration ${dur} s, transport $transport, timing $timing, commit $(git rev-parse --short HEAD 2>/dev/null || echo '?'))"
sed "s/^  duration: .*/  duration: $dur/" config/scenarios/paper.yaml > "$work/scenario.yaml"
dep="$work/secure.yaml"
{
  echo "name: secure-starts"
  echo "domain_id: ${DOMAIN_BASE:-150}"
  echo "transport: $transport"
  echo "timing: $timing"
  echo "timeout: 10"
  printf "security:\n  keys: keys\n"
  echo "modules:"
  for i in $(seq 1 "$mods"); do echo "  - {name: m$i, scenario: scenario.yaml, case: SOSM}"; done
} > "$dep"
passed=0; repaired=0; repairs=0; times=()
for r in $(seq 1 "$reps"); do
  # A new domain per start (nothing of the previous start can be heard), with keys made for it (the permissions
  # grant one domain).
  domain=$(( ${DOMAIN_BASE:-150} + r % 20 ))
  sed -i "s/^domain_id: .*/domain_id: $domain/; s/^  keys: .*/  keys: keys$domain/" "$dep"
  [ -d "$work/keys$domain" ] || "$bin/tandem" keys "$dep" > /dev/null || { echo "secure_starts.sh: tandem keys failed" >&2; exit 1; }
  log="$work/up$r.log"; sum="$work/sum$r.txt"
  start=$(date +%s.%N)
  rc=0
  timeout 200 "$bin/tandem" up "$dep" --summary "$sum" > "$log" 2>&1 || rc=$?
  n=$(sed -n 's/^start_repairs=//p' "$sum" 2>/dev/null || true); n=${n:-?}
  # Start-up: launch to the last world's first tick (the launcher prints it with the wall time).
  first=$(sed -n 's/.*first tick at wall \([0-9.]*\).*/\1/p' "$log" | sort -n | tail -1)
  t="?"; [ -n "$first" ] && t=$(python3 -c "print(f'{$first - $start:.2f}')")
  if [ "$rc" -eq 0 ]; then passed=$((passed + 1)); result=pass; else result="FAIL($rc)"; cp "$log" "/tmp/secure_starts_fail$r.log"; fi
  if [ "$n" != "?" ] && [ "$n" -gt 0 ]; then repaired=$((repaired + 1)); repairs=$((repairs + n)); fi
  [ "$t" != "?" ] && times+=("$t")
  printf "start %3d: %-8s repairs %s  start-up %s s\n" "$r" "$result" "$n" "$t"
done
stats=$(printf "%s\n" "${times[@]}" | python3 -c "
import sys, statistics
v = [float(x) for x in sys.stdin.read().split()]
print(f'start-up median {statistics.median(v):.2f} s, max {max(v):.2f} s' if v else 'no start-up time')")
echo "summary: $reps starts of $mods module(s): $passed passed, $repaired needed a repair ($repairs repairs), $stats"
[ "$passed" -eq "$reps" ]
