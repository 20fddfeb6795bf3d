#!/usr/bin/env bash
# Cost of placing a module's robots on other hosts, measured with network namespaces as hosts (root), in one run:
#  1. bare Fast DDS ping-pong at 1 kHz: both ends on host a (shared memory), and ping on a, pong on b (UDP
#     over a veth pair and a bridge);
#  2. one module in real time with a standby per arm, REPS times each, alternating: every process on host a,
#     and world + supervisor on a, robots on b, standbys on c. Sample->command latency p50/p99 and late
#     arm-ticks from the world's summary.
# Prints one line per run and the medians. Usage: bench/multihost.sh [REPS]   (build first; as root)
set -euo pipefail
cd "$(dirname "$0")/.."
reps=${1:-3}
bin=$PWD/build/bin
[ "$(id -u)" = 0 ] || { echo "bench/multihost.sh: network namespaces need root" >&2; exit 1; }
p=tbench net=10.79.0 domain=$(( 150 + $$ % 50 ))
work=$(mktemp -d)
pids=()
cleanup() {
  for q in "${pids[@]}"; do kill "$q" 2>/dev/null || true; done
  bash scripts/netns-hosts.sh down "$p" a b c > /dev/null
  rm -rf "$work"
}
trap cleanup EXIT
bash scripts/netns-hosts.sh down "$p" a b c > /dev/null
bash scripts/netns-hosts.sh up "$p" "$net" a b c > /dev/null
echo "machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), kernel $(uname -r); domain $domain"

pingpong() {  # label pong-host
  ip netns exec "$p-$2" "$bin/tandem_bench_pingpong" pong --domain "$domain" --seconds 20 > /dev/null &
  local pong=$!
  ip netns exec "$p-a" "$bin/tandem_bench_pingpong" ping --domain "$domain" --count 5000 > "$work/pp.txt"
  kill "$pong" 2>/dev/null || true; wait "$pong" 2>/dev/null || true
  echo "pingpong $1: p50 $(sed -n 's/^pingpong_p50_us=//p' "$work/pp.txt") us, p99 $(sed -n 's/^pingpong_p99_us=//p' "$work/pp.txt") us"
}
pingpong "a<->a (one host)" a
pingpong "a<->b (two hosts)" b

deploy() {  # robots-host standbys-host
  cat <<EOF
name: mh-bench
domain_id: $domain
timing: realtime
timeout: 10
discovery: server
discovery_address: $net.1
hosts:
  a: {address: $net.1}
  b: {address: $net.2}
  c: {address: $net.3}
modules:
  - name: m1
    scenario: $PWD/config/scenarios/paper.yaml
    case: SOSM
    host: a
    standby: 1
    robot_hosts: {left: $1, right: $1}
    standby_hosts: {left: $2, right: $2}
EOF
}
deploy a a > "$work/one.yaml"
deploy b c > "$work/three.yaml"
run() {  # label file
  for h in a b c; do
    ip netns exec "$p-$h" "$bin/tandem" agent "$2" --host "$h" --once > "$work/agent-$h.log" 2>&1 &
    pids+=($!)
  done
  ip netns exec "$p-a" "$bin/tandem" up "$2" --summary "$work/s.txt" > "$work/up.log" 2>&1 || { cat "$work/up.log"; exit 1; }
  for q in "${pids[@]}"; do wait "$q" || true; done
  pids=()
  local p50 p99 late
  p50=$(sed -n 's/^m1.latency_p50_us=//p' "$work/s.txt"); p99=$(sed -n 's/^m1.latency_p99_us=//p' "$work/s.txt")
  late=$(sed -n 's/^m1.late_commands=//p' "$work/s.txt")
  echo "$1 p50_us=$p50 p99_us=$p99 late_arm_ticks=$late" | tee -a "$work/runs.txt"
}
for i in $(seq "$reps"); do
  run one-host "$work/one.yaml"
  run three-hosts "$work/three.yaml"
done
median() { sort -n | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }
for label in one-host three-hosts; do
  line="$label median of $reps:"
  for key in p50_us p99_us late_arm_ticks; do
    line="$line $key=$(grep "^$label " "$work/runs.txt" | grep -o "$key=[0-9.]*" | cut -d= -f2 | median)"
  done
  echo "$line"
done
