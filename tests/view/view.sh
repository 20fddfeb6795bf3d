#!/usr/bin/env bash
# tandem view against a running lockstep deployment (docs/view.md), with real processes and independent clients:
#  1. bad command lines are refused with what is accepted;
#  2. a Foxglove-protocol client of our own on the ws package (tests/tools/view/foxglove_client.mjs) subscribes to
#     a per-tick protobuf channel, decodes it with protobufjs from the advertised schema, and gets consecutive ticks;
#  3. a client that subscribes to everything and never reads for 15 s: the viewer's resident memory stays within
#     the bound stated in docs/view.md, and the next client is served (drops and late ticks: the benchmark's);
#  4. the page in headless Chromium: the process table fills, the plots grow, an event appears when a robot is
#     killed with the page's own kill button (confirmed, answered ok; bad API requests refused first), no
#     console errors; a screenshot is kept
#     (WORK/page.png);
#  5. the same page over the run's recording (tandem view run.mcap): replay mode, a slider over the run, tables,
#     plots and events at its time (WORK/replay.png);
#  6. `tandem up --view-port 0` starts the viewer beside a short run and stops it at the end.
# Usage: view.sh BIN_DIR SRC WORK NODE_DIR DOMAIN
set -euo pipefail
bin=$1 src=$2 work=$3 node=$4 domain=$5
rm -rf "$work"; mkdir -p "$work"; cd "$work"
pids=()
# Reaped even when one ignores SIGTERM (headless Chromium's driver may: the test then hung in `wait`).
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  for _ in $(seq 50); do
    alive=0; for p in "${pids[@]}"; do kill -0 "$p" 2>/dev/null && alive=1; done
    [ "$alive" -eq 0 ] && break; sleep 0.1
  done
  for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null || true; wait "$p" 2>/dev/null || true; done
}
trap cleanup EXIT
# The logs first and the reason last: CI shows the end of a failed test's output.
fail() { for f in up.log view.log; do [ -f "$f" ] && { echo "--- $f"; tail -20 "$f"; }; done; echo "FAIL: $*"; exit 1; }

echo "== 1. bad command lines"
rc=0; "$bin/tandem" view > bad1.log 2>&1 || rc=$?
[ "$rc" -eq 2 ] && grep -q "source is required" bad1.log || fail "no file: expected exit 2 (got $rc)"
rc=0; "$bin/tandem" view x.yaml --port 70000 > bad2.log 2>&1 || rc=$?
[ "$rc" -eq 2 ] && grep -q "not a port number 0-65535" bad2.log || fail "bad port: expected exit 2 (got $rc)"
rc=0; "$bin/tandem" view x.yaml --frobnicate > bad3.log 2>&1 || rc=$?
[ "$rc" -eq 2 ] && grep -q "unknown option or extra argument '--frobnicate'" bad3.log || fail "unknown option: expected exit 2 (got $rc)"
rc=0; "$bin/tandem" view "$work/none.yaml" > bad4.log 2>&1 || rc=$?
[ "$rc" -eq 2 ] || fail "a missing deployment file: expected exit 2 (got $rc)"

# One module with a hot standby per arm, in lockstep, long enough for every check (120 s of simulated motion).
sed "s/ duration: 5.0 / duration: 120.0 /" "$src/config/scenarios/paper.yaml" > long.yaml
cat > d.yaml <<YAML
name: view-test
domain_id: $domain
transport: udp
timing: lockstep
timeout: 20
modules:
  - {name: m1, scenario: long.yaml, case: SOSM, standby: 1, restart: on-failure}
YAML
"$bin/tandem" up d.yaml --record "$work/run.mcap" > up.log 2>&1 & pids+=($!); up=$!
"$bin/tandem" view d.yaml --port 0 > view.log 2>&1 & pids+=($!); viewer=$!
for _ in $(seq 100); do grep -q "^tandem view: .* at http" view.log && break; sleep 0.1; done
port=$(sed -n 's/^tandem view: .* at http:\/\/127\.0\.0\.1:\([0-9]*\)\/.*/\1/p' view.log)
[ -n "$port" ] || fail "the viewer printed no URL"
echo "viewer on port $port"
get() { node -e 'fetch(process.argv[1]).then(async r => { console.log(r.status); console.log(await r.text()); })' "$1"; }
get "http://127.0.0.1:$port/" > index.out; head -1 index.out | grep -q 200 && grep -q "<title>tandem view</title>" index.out \
  || fail "GET / did not serve the page"
# (each answer to a file first: `get | head -1` under pipefail fails whenever head closes the pipe before node is done)
get "http://127.0.0.1:$port/uPlot.iife.min.js" > uplot.out; head -1 uplot.out | grep -q 200 || fail "uPlot is not served"
get "http://127.0.0.1:$port/etc/passwd" > passwd.out; head -1 passwd.out | grep -q 404 || fail "a file that is not the page's was served"

echo "== 2. an independent Foxglove client gets consecutive ticks"
node "$node/foxglove_client.mjs" "ws://127.0.0.1:$port" tandem/torque_commands/m1/left 500 || fail "foxglove client"

echo "== 3. a client that never reads"
rss() { awk '/^VmRSS/ {print $2}' "/proc/$viewer/status"; }
rss0=$(rss)
node "$node/foxglove_client.mjs" "ws://127.0.0.1:$port" tandem/arm_sensors/m1/left 1 --stall 15 > stall.log 2>&1 || fail "stalled client: $(cat stall.log)"
rss1=$(rss)
echo "viewer RSS ${rss0} kB before, ${rss1} kB after 15 s of a client that read nothing"
# Bound (docs/view.md): per client at most 1000 frames per channel; 40 MiB of growth is far above that for one
# client here and far below what an unbounded queue of 15 s of every channel would take.
[ $(( rss1 - rss0 )) -lt 40960 ] || fail "the viewer grew $(( rss1 - rss0 )) kB with one stalled client"
node "$node/foxglove_client.mjs" "ws://127.0.0.1:$port" tandem/torque_commands/m1/right 200 || fail "a client after the stalled one"
# The stalled client's queues dropped their oldest frames, and the server counted them: the page's state says so.
node "$node/foxglove_client.mjs" "ws://127.0.0.1:$port" tandem/view/state 50 --drops || fail "no drop counted for the stalled client"

echo "== 4. the page in headless Chromium"
# The checker clicks m1/left's kill button once it reads a line on its stdin (a fifo held open here).
rm -f go.fifo; mkfifo go.fifo
node "$node/check_view_page.mjs" "http://127.0.0.1:$port/" m1/left "$work/page.png" < go.fifo > page.log 2>&1 & page=$!
pids+=("$page")
exec 7> go.fifo
for _ in $(seq 600); do grep -q "^READY" page.log && break; kill -0 "$page" 2>/dev/null || break; sleep 0.1; done
grep -q "^READY" page.log || { cat page.log; fail "the page never got ready"; }
# The page's live-command API (POST /api/command) runs `tandem kill` as the CLI would; bad requests are refused with
# what is accepted, and change nothing. Then the checker kills m1/left with the page's own button.
post() { node -e 'fetch(process.argv[1], {method: "POST", headers: {"Content-Type": "application/json"}, body: process.argv[2]})
  .then(async r => { console.log(r.status); console.log(await r.text()); })' "$1" "$2"; }
post "http://127.0.0.1:$port/api/command" '{"command": "explode", "target": "m1/left"}' > cmd_bad.out
head -1 cmd_bad.out | grep -q 400 && grep -q "accepted: down, kill, plug, unplug" cmd_bad.out || { cat cmd_bad.out; fail "a bad live command"; }
post "http://127.0.0.1:$port/api/command" '{"command": "kill", "target": "m1/left; rm -rf /"}' > cmd_bad2.out
head -1 cmd_bad2.out | grep -q 400 || { cat cmd_bad2.out; fail "a target that is no name"; }
get "http://127.0.0.1:$port/api/command" > cmd_get.out; head -1 cmd_get.out | grep -q 405 || fail "GET /api/command was not refused"
# (a checker that died meanwhile has closed the fifo: no GO then, and its log says why)
if kill -0 "$page" 2>/dev/null; then { echo GO >&7; } 2>/dev/null || true; fi
exec 7>&-
rc=0; wait "$page" || rc=$?
cat page.log
[ "$rc" -eq 0 ] || fail "the page check"

echo "== 5. the same page over the recording"
"$bin/tandem" down d.yaml > down.log 2>&1 || true
wait "$up" || true
[ -s run.mcap ] || fail "no recording"
"$bin/tandem" view "$work/run.mcap" --port 0 > replay.log 2>&1 & pids+=($!)
for _ in $(seq 100); do grep -q "^tandem view: .* at http" replay.log && break; sleep 0.1; done
rport=$(sed -n 's/^tandem view: .* at http:\/\/127\.0\.0\.1:\([0-9]*\)\/.*/\1/p' replay.log)
[ -n "$rport" ] || { cat replay.log; fail "the replay viewer printed no URL"; }
node "$node/check_view_replay.mjs" "http://127.0.0.1:$rport/" "$work/replay.png" || fail "the replay page"

echo "== 6. tandem up --view starts the viewer beside the deployment and stops it at the end"
sed "s/long.yaml/short.yaml/; s/standby: 1, //" d.yaml > short-d.yaml
cp "$src/config/scenarios/paper.yaml" short.yaml
rc=0; "$bin/tandem" up short-d.yaml --view-port 0 > upview.log 2>&1 || rc=$?
[ "$rc" -eq 0 ] || { tail -20 upview.log; fail "tandem up --view exited $rc"; }
grep -q "^tandem view: view-test (domain $domain) at http://127.0.0.1:" upview.log || fail "no viewer URL from tandem up --view"
grep -q "^tandem view: stopped" upview.log || fail "the viewer was not stopped at the end"
echo "PASS"
