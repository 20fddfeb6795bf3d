#!/usr/bin/env bash
# Closed-loop latency across processes, measured beside a bare Fast DDS ping-pong in the same run:
#  1. bare ping-pong between two processes at 1 kHz (same participant set-up and QoS as the runtime);
#  2. the one-module deployment in real time: world sample -> robot torque command latency and late ticks.
# Prints key=value lines and the ratio runtime/ping-pong. Usage: bench/loop.sh [domain]   (build first)
set -euo pipefail
cd "$(dirname "$0")/.."
domain="${1:-$(( 150 + $$ % 50 ))}"
bin=build/bin
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), kernel $(uname -r)"
echo "domain: $domain"

"$bin/tandem_bench_pingpong" pong --domain "$domain" --seconds 20 &
pong=$!
"$bin/tandem_bench_pingpong" ping --domain "$domain" --count 5000 | tee "$work/pp.txt"
kill "$pong" 2>/dev/null || true
wait "$pong" 2>/dev/null || true

sed "s/^domain_id: .*/domain_id: $domain/" deploy/one-module-realtime.yaml > "$work/rt.yaml"
sed -i "s|scenario: ../config|scenario: $PWD/config|" "$work/rt.yaml"
"$bin/tandem" up "$work/rt.yaml" --summary "$work/rt.txt" > "$work/up.log" || { cat "$work/up.log"; exit 1; }
grep "real time" "$work/up.log"
p50=$(sed -n 's/^m1.latency_p50_us=//p' "$work/rt.txt")
p99=$(sed -n 's/^m1.latency_p99_us=//p' "$work/rt.txt")
late=$(sed -n 's/^m1.late_commands=//p' "$work/rt.txt")
pp50=$(sed -n 's/^pingpong_p50_us=//p' "$work/pp.txt")
pp99=$(sed -n 's/^pingpong_p99_us=//p' "$work/pp.txt")
echo "runtime_p50_us=$p50"
echo "runtime_p99_us=$p99"
echo "runtime_late_arm_ticks=$late (of 10000)"
awk -v a="$p50" -v b="$pp50" -v c="$p99" -v d="$pp99" 'BEGIN { printf "ratio_p50=%.2f\nratio_p99=%.2f\n", a / b, c / d }'
