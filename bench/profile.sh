#!/usr/bin/env bash
# What separates the runtime from its floor (docs/benchmarks.md, "Where the rest goes"): one basic module in real
# time (the paper's SOSM case, shared memory, SCHED_FIFO) and, right after, the bare layout of the same shape
# (bench/floor.cpp: a world process on a 1 kHz timer, two robot processes, futex wake-ups, plant-sized work, no
# DDS). For each, over the same steady-state window, per process and per tick: CPU (utime + stime), context
# switches (voluntary: a thread went to sleep and was woken; involuntary: preempted) and threads. Then a
# system-wide perf profile of the runtime's window, split by shared object and by the top symbols, so that the
# cost per tick can be read as: kernel (wake-ups, futex, scheduler), Fast DDS, libc, the project's own code.
#
# Usage: bash bench/profile.sh [SECONDS]     default 4 (the measured window; needs perf from linux-perf)
#   env: PRIO (realtime_priority, default 20), DOMAIN_BASE (default 190), KEEP=DIR (keep perf.data and logs)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/bin
[ -x "$bin/tandem" ] && [ -x "$bin/tandem_bench_floor" ] || { echo "profile.sh: build first (bash scripts/build.sh)" >&2; exit 2; }
command -v perf >/dev/null || { echo "profile.sh: perf is missing (apt-get install linux-perf)" >&2; exit 2; }
secs="${1:-4}"
[[ "$secs" =~ ^[0-9]+$ ]] && [ "$secs" -ge 1 ] && [ "$secs" -le 60 ] || { echo "profile.sh: SECONDS must be an integer in [1, 60], got '$secs'" >&2; exit 2; }
prio="${PRIO:-20}"
work="${KEEP:-$(mktemp -d)}"
mkdir -p "$work"
[ -n "${KEEP:-}" ] || trap 'rm -rf "$work"' EXIT
hz=$(getconf CLK_TCK)
echo "machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), kernel $(uname -r)"
echo "command: bash bench/profile.sh $secs  (realtime_priority $prio, commit $(git rev-parse --short HEAD 2>/dev/null || echo '?'))"
sed "s/^  duration: .*/  duration: $((secs + 15))/" config/scenarios/paper.yaml > "$work/scenario.yaml"
cat > "$work/profile.yaml" <<EOF
name: profile
domain_id: ${DOMAIN_BASE:-190}
transport: shm
timing: realtime
realtime_priority: $prio
timeout: 60
modules:
  - {name: m1, scenario: scenario.yaml, case: SOSM}
EOF

# Per process: "pid name cpu_ticks voluntary involuntary threads" at this moment.
snap() {
  for p in "$@"; do
    [ -r "/proc/$p/stat" ] || continue
    local cpu name vol inv thr
    cpu=$(awk '{print $14 + $15}' "/proc/$p/stat" 2>/dev/null) || continue
    name=$(tr '\0' ' ' < "/proc/$p/cmdline" 2>/dev/null | awk '{n = $1; sub(".*/", "", n); r = ""; for (i = 2; i <= NF; i++) if ($i == "--arm" || $i == "--role") r = $(i + 1); print n (r != "" ? "/" r : "")}')
    vol=0; inv=0
    for t in /proc/$p/task/*; do
      read -r a b < <(awk '/^voluntary_ctxt_switches/ {v = $2} /^nonvoluntary_ctxt_switches/ {n = $2} END {print v + 0, n + 0}' "$t/status" 2>/dev/null || echo "0 0")
      vol=$((vol + a)); inv=$((inv + b))
    done
    thr=$(ls "/proc/$p/task" 2>/dev/null | wc -l)
    echo "$p $name $cpu $vol $inv $thr"
  done
  return 0
}
# Differences of two snapshots, per process and in all, per tick (1 kHz over the window).
report() {  # t0 t1 seconds label
  awk -v hz="$hz" -v s="$3" -v label="$4" '
    NR == FNR {c[$1] = $3; v[$1] = $4; i[$1] = $5; next}
    ($1 in c) {
      dc = ($3 - c[$1]) / hz / s; dv = ($4 - v[$1]) / (1000 * s); di = ($5 - i[$1]) / (1000 * s)
      printf "  %-10s %-26s cpu %.3f core   switches per tick: woken %.2f, preempted %.2f   threads %d\n", label, $2, dc, dv, di, $6
      C += dc; V += dv; I += di; T += $6
    }
    END {printf "  %-10s %-26s cpu %.3f core   switches per tick: woken %.2f, preempted %.2f   threads %d\n", label, "all", C, V, I, T}' "$1" "$2"
}

echo "== the runtime: one module"
log="$work/up.log"
"$bin/tandem" up "$work/profile.yaml" --summary "$work/sum.txt" > "$log" 2>&1 &
up=$!
while kill -0 "$up" 2>/dev/null && ! grep -q "first tick at wall" "$log"; do sleep 0.1; done
sleep 2
pids=$( (pgrep -P "$up" -f "tandem-(world|robot|supervisor)" || true) | tr '\n' ' ')
# shellcheck disable=SC2086
snap $pids > "$work/r0"
perf record -a -F 4999 -o "$work/perf.data" -- sleep "$secs" > "$work/perf.log" 2>&1
# shellcheck disable=SC2086
snap $pids > "$work/r1"
report "$work/r0" "$work/r1" "$secs" runtime
kill -INT "$up" 2>/dev/null || true
rc=0; wait "$up" || rc=$?

echo "== the floor: the same layout without DDS (bench/floor.cpp)"
"$bin/tandem_bench_floor" --modules 1 --seconds "$((secs + 4))" --robot-us 1 --world-us 45 --fifo "$prio" > "$work/floor.txt" 2>&1 &
fl=$!
sleep 2
fpids=$( (pgrep -P "$fl" || true) | tr '\n' ' ')
# shellcheck disable=SC2086
snap $fl $fpids > "$work/f0"
sleep "$secs"
# shellcheck disable=SC2086
snap $fl $fpids > "$work/f1"
report "$work/f0" "$work/f1" "$secs" floor
wait "$fl" || true

echo "== the runtime's window, system-wide, by shared object (% of all samples; both cores)"
perf report -i "$work/perf.data" --comm tandem-world,tandem-robot,tandem-supervisor --sort comm,dso --stdio 2>/dev/null \
  | grep -v '^#' | grep -v '^$' | head -16
echo "== the top symbols of the role processes"
perf report -i "$work/perf.data" --comm tandem-world,tandem-robot,tandem-supervisor --sort dso,sym --stdio 2>/dev/null \
  | grep -v '^#' | grep -v '^$' | head -30
[ -n "${KEEP:-}" ] && echo "kept: $work"
exit 0
