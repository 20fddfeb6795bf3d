#!/usr/bin/env bash
# Do per-tick endpoints survive their peers being SIGKILLed mid-sample? Two cases, each with KILLS kills:
#  writers: one reader runs for the whole test; a writer is started, writes as fast as it can for a random
#           150-450 ms, and is SIGKILLed (the world's torque readers while robots are killed and restarted);
#  readers: one writer runs at 1 kHz for the whole test; a reader is started, reads for 150-450 ms, and is
#           SIGKILLed (the world's sensor writers while robots are killed).
# Reported: the kills done, whether the long-lived process was still alive after each (and how it ended if not),
# the samples it moved, and (readers case) its longest write(). Fast DDS 2.9.1's data-sharing delivery aborts the
# reader's process when a writer dies at the wrong moment (an assertion in ReaderPool::init_shared_segment, or an
# uncaught "Interprocess mutex timeout when locking" from a lock the dead writer held); its shared-memory
# transport does not (docs/benchmarks.md, "Per-tick delivery and killed peers").
# Usage: bench/peer_kill.sh [KILLS] [datasharing|shm|udp] [writers|readers] [domain]
set -uo pipefail
cd "$(dirname "$0")/.."
kills="${1:-200}"
delivery="${2:-datasharing}"
victims="${3:-writers}"
domain="${4:-$(( 200 + $$ % 30 ))}"
case "$victims" in writers|readers) ;; *) echo "peer_kill: victims must be writers or readers, got '$victims'" >&2; exit 2 ;; esac
bin=build/bin/tandem_bench_peer_kill
[ -x "$bin" ] || { echo "peer_kill: build first (cmake --build build --target tandem_bench_peer_kill)" >&2; exit 2; }
work=$(mktemp -d)
stamp="$work/stamp"
touch "$stamp"
keeper=""
victim=""
cleanup() {
  [ -n "$victim" ] && kill -9 "$victim" 2>/dev/null
  [ -n "$keeper" ] && kill "$keeper" 2>/dev/null
  wait 2>/dev/null
  # Files the killed processes left (their participants could not remove them).
  find /dev/shm -maxdepth 1 -user "$(id -u)" -newer "$stamp" \( -name 'fast_*' -o -name 'sem.fast_*' \) -exec rm -f {} + 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT
echo "machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), kernel $(uname -r)"
echo "delivery: $delivery, killed: $victims, kills: $kills, domain: $domain"
if [ "$victims" = writers ]; then
  keep_args=(reader); victim_args=(writer)
else
  keep_args=(writer --rate 1000); victim_args=(reader)
fi
"$bin" "${keep_args[@]}" --domain "$domain" --delivery "$delivery" --seconds 100000 > "$work/keeper.out" 2> "$work/keeper.err" &
keeper=$!
sleep 1
done_kills=0
status=alive
for ((i = 1; i <= kills; i++)); do
  "$bin" "${victim_args[@]}" --domain "$domain" --delivery "$delivery" --seconds 100000 > /dev/null 2>&1 &
  victim=$!
  sleep "0.$(( 150 + RANDOM % 300 ))"
  kill -9 "$victim" 2>/dev/null
  wait "$victim" 2>/dev/null
  victim=""
  done_kills=$i
  if ! kill -0 "$keeper" 2>/dev/null; then
    wait "$keeper"
    status="died (exit $?) after kill $i"
    keeper=""
    break
  fi
done
sleep 2
last=$(tail -n 1 "$work/keeper.out")
echo "peer_kill_kills=$done_kills"
echo "peer_kill_survivor=$status"
echo "peer_kill_last=${last:-none}"
if [ -s "$work/keeper.err" ]; then
  echo "survivor's stderr (last lines):"
  tail -n 5 "$work/keeper.err" | cut -c1-300
fi
[ "$status" = alive ]
