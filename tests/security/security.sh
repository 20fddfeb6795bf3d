#!/usr/bin/env bash
# DDS-Security of a deployment (docs/security.md), with real processes and keys made by `tandem keys`:
#  1. bad input: keys missing or expired -> `tandem up` refuses with the file's name, nothing starts;
#  2. the default deployment with security on runs and passes, with the same RMS as without;
#  3. while a secured real-time deployment runs, a participant without valid credentials
#     - cannot read the sensor topic (plain Fast DDS: a recorder; another vendor: Cyclone DDS, if built),
#     - cannot stop the deployment (`tandem down` without credentials), cannot command an arm (no world matches
#       its torque writer),
#     and a robot's identity cannot command the other arm (access control refuses the writer), while it can
#     write its own (the control), and the CLI's identity can stop it;
#  4. a packet capture of a secured run over UDP holds none of the sensor samples' values, where the same run
#     without security holds them all (the check can fail).
# Usage: security.sh BIN_DIR SRC WORK DOMAIN_BASE [CYCLONE_OBSERVER]
set -euo pipefail
bin=$1 src=$2 work=$3 base=$4 cyclone=${5:-}
rm -rf "$work"; mkdir -p "$work"; cd "$work"
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; wait "$p" 2>/dev/null || true; done; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; exit 1; }
# A pair of secured participants that never authenticates at start-up (a race in Fast DDS 2.9.1, docs/security.md)
# is repaired by the launcher: it restarts the module with new participants (counted in start_repairs). The run
# must pass whether or not a repair was needed; the count is printed.
up_secured() {  # file summary log
  local rc=0
  "$bin/tandem" up "$1" --summary "$2" > "$3" 2>&1 || rc=$?
  echo "$1: start-up repairs $(sed -n 's/^start_repairs=//p' "$2" 2>/dev/null)"
  # No retry: the world and the robots take part only once the launcher's summary reader has matched them, so a
  # passing run has every robot's summary (a pair that never matched is repaired before the first tick).
  if [ "$rc" -eq 0 ] && [ "$(grep -c '\.ep_pos_rms=' "$2")" -lt 2 ]; then
    echo "$1 passed without every robot's summary reaching the launcher"; rc=1
  fi
  return "$rc"
}
sed "s/ duration: 5.0 / duration: 120.0 /" "$src/config/scenarios/paper.yaml" > long.yaml
deploy() {  # name domain timing transport scenario security(yes|no)
  {
    # Secured runs wait up to 20 s for their peers (a healthy handshake takes a second or two on a loaded machine;
    # past that the launcher repairs the module).
    echo "name: $1"; echo "domain_id: $2"; echo "timing: $3"; echo "transport: $4"; echo "timeout: $([ "$6" = yes ] && echo 20 || echo 10)"
    [ "$6" = yes ] && printf "security:\n  keys: keys\n"
    printf "modules:\n  - {name: m1, scenario: %s, case: SOSM}\n" "$5"
  }
}

echo "== 1. missing and expired keys are refused, naming the file"
deploy secure "$base" lockstep shm "$src/config/scenarios/paper.yaml" yes > secure.yaml
deploy secure "$base" lockstep shm "$src/config/scenarios/paper.yaml" no > plain.yaml
rc=0; "$bin/tandem" up secure.yaml > up0.log 2>&1 || rc=$?
[ "$rc" -eq 2 ] && grep -q "keys/ca.pem is missing" up0.log && grep -q "tandem keys secure.yaml" up0.log \
  || { cat up0.log; fail "missing keys: expected exit 2 naming keys/ca.pem (got $rc)"; }
"$bin/tandem" keys secure.yaml > keys.log 2>&1 || { cat keys.log; fail "tandem keys"; }
for f in ca.pem governance.p7s permissions.p7s robot.m1.left.pem robot.m1.left.key cli.pem launcher.key; do
  [ -s "keys/$f" ] || fail "tandem keys did not make keys/$f"
done
[ "$(stat -c %a keys/robot.m1.left.key)" = 600 ] || fail "a private key is not 0600"
# An expired identity: a certificate that ended yesterday (same CA).
cp keys/world.m1.pem world.m1.pem.good
openssl req -new -key keys/world.m1.key -subj /CN=world.m1 -out w.csr 2>/dev/null
openssl x509 -req -in w.csr -CA keys/ca.pem -CAkey keys/ca.key -set_serial 7 -days -1 -out keys/world.m1.pem 2>/dev/null \
  || fail "openssl could not make an expired certificate"
rc=0; "$bin/tandem" up secure.yaml > up1.log 2>&1 || rc=$?
[ "$rc" -eq 2 ] && grep -q "world.m1.pem has expired" up1.log || { cat up1.log; fail "expired certificate: expected exit 2"; }
echo "expired certificate refused: $(grep -o 'security: .*' up1.log | head -1)"
cp world.m1.pem.good keys/world.m1.pem

echo "== 2. the default deployment with security runs and passes, with the same numbers"
up_secured secure.yaml secure.sum up2.log || { tail -30 up2.log; fail "secured run did not pass"; }
sed -i "s/domain_id: $base/domain_id: $((base + 1))/" plain.yaml
"$bin/tandem" up plain.yaml --summary plain.sum > up3.log 2>&1 || { tail -30 up3.log; fail "plain run did not pass"; }
for key in m1/left.ep_pos_rms m1/right.eh_rms m1.ticks; do
  a=$(grep "^$key=" secure.sum || true); b=$(grep "^$key=" plain.sum || true)
  [ -n "$a" ] && [ -n "$b" ] || fail "$key missing from a summary (secured: '$a', plain: '$b')"
  [ "$a" = "$b" ] || fail "secured and plain runs differ: $a vs $b"
done
echo "secured run: $(grep '^result' up2.log); $(grep '^m1/left.ep_pos_rms' secure.sum) as without security"

echo "== 3. a running secured deployment and participants without valid credentials"
d3=$((base + 2))
deploy live "$d3" realtime shm long.yaml yes > live.yaml
deploy live "$d3" realtime shm long.yaml no > live-plain.yaml
"$bin/tandem" keys live.yaml > keys3.log 2>&1 || { cat keys3.log; fail "tandem keys live.yaml"; }
# Started until every process is heard on the domain. A process the launcher never hears within 15 s (a pair that
# never authenticated) is killed and its module restarted with new participants (counted as a start-up repair).
"$bin/tandem" up live.yaml --summary live.sum > up4.log 2>&1 &
pids+=($!); up=$!
for i in $(seq 1000); do grep -q "all [0-9]* process(es) heard on the domain" up4.log && break; sleep 0.05; done
grep -q "all [0-9]* process(es) heard on the domain" up4.log || { cat up4.log; fail "the secured deployment did not come up"; }
grep -q "did not come up" up4.log && echo "start-up repair: $(grep -m1 'did not come up' up4.log)"
for i in $(seq 800); do grep -q "first tick at wall" up4.log && break; sleep 0.05; done
grep -q "first tick at wall" up4.log || { cat up4.log; fail "the secured deployment did not start"; }
# Secured participants take discovery and handshakes on one unicast port, no multicast (the Fast DDS 2.9.1
# handshake race needs two receive threads: docs/security.md, "Start-up"). A plain participant listens on the
# domain's multicast discovery port 7400 + 250 * domain; the secured world must not.
world=$(sed -n 's/^  started m1\/world *pid \([0-9]*\).*/\1/p' up4.log | tail -1)
[ -n "$world" ] || fail "no world pid in the launcher's output"
ports=$(ss -uanp | grep "pid=$world," | awk '{print $4}' | sed 's/.*://' | sort -n | tr '\n' ' ')
echo "secured world's UDP ports: $ports"
case " $ports " in *" $((7400 + 250 * d3)) "*) fail "the secured world listens on the multicast discovery port";; esac
metas=0
for p in $ports; do
  o=$((p - 7410 - 250 * d3))
  if [ "$o" -ge 0 ] && [ "$o" -lt 240 ] && [ $((o % 2)) -eq 0 ]; then metas=$((metas + 1)); fi
done
[ "$metas" -eq 1 ] || fail "the secured world listens on $metas metatraffic unicast ports (expected 1): $ports"
# Plain Fast DDS without credentials: reads nothing (a recorder of the sensor topics), hears no launcher.
"$bin/tandem" record live-plain.yaml -o plain.mcap --topics ticks --duration 3 > rec.log 2>&1 || true
grep -q "(0 per-tick samples)" rec.log || { cat rec.log; fail "a participant without credentials read sensor samples"; }
rc=0; "$bin/tandem" status live-plain.yaml > st.log 2>&1 || rc=$?
[ "$rc" -ne 0 ] || { cat st.log; fail "tandem status without credentials saw the deployment"; }
rc=0; "$bin/tandem" down live-plain.yaml > down-plain.log 2>&1 || rc=$?
[ "$rc" -ne 0 ] || { cat down-plain.log; fail "tandem down without credentials was obeyed"; }
kill -0 "$up" 2>/dev/null || fail "the deployment stopped after a down request without credentials"
out=$("$bin/tandem_intruder" --domain "$d3" --arm m1/left --seconds 2) || true
echo "no credentials, torque writer for m1/left: $out"
[ "$out" = "writer=created matched=0" ] || fail "a writer without credentials was matched by the world: $out"
if [ -n "$cyclone" ]; then
  out=$("$cyclone" "$d3" sensors m1/left 10 3) || true
  echo "Cyclone DDS without credentials: $out"
  grep -q "^samples=0 " <<< "$out" || fail "another vendor without credentials read sensor samples: $out"
fi
# A robot's identity: its own arm yes (the control), the other arm no.
out=$(TANDEM_SECURITY_DIR="$PWD/keys" TANDEM_IDENTITY=robot.m1.left "$bin/tandem_intruder" --domain "$d3" --arm m1/right --seconds 1) && rc=0 || rc=$?
echo "identity robot.m1.left, torque writer for m1/right: $out"
[ "$rc" -eq 3 ] || fail "the left robot's identity could create a torque writer for the right arm: $out"
out=$(TANDEM_SECURITY_DIR="$PWD/keys" TANDEM_IDENTITY=robot.m1.left "$bin/tandem_intruder" --domain "$d3" --arm m1/left --seconds 15 --until-matched) && rc=0 || rc=$?
echo "identity robot.m1.left, torque writer for m1/left: $out"
[ "$rc" -eq 0 ] && grep -q "matched=[1-9]" <<< "$out" || fail "the left robot's own identity could not write its arm: $out"
# The CLI's identity: `tandem status` sees it, `tandem down` stops it.
s0=$(date +%s.%N); "$bin/tandem" status live.yaml > st2.log 2>&1 || { cat st2.log; echo "after $(awk -v s=$s0 -v e=$(date +%s.%N) "BEGIN {print e - s}") s"; tail -5 up4.log; fail "tandem status with the identity of the CLI"; }
grep -q "m1/world" st2.log || { cat st2.log; fail "tandem status with credentials did not list the world"; }
"$bin/tandem" down live.yaml > down.log 2>&1 || { cat down.log; fail "tandem down with the CLI's identity"; }
wait "$up" || true
pids=()
grep -q "'down' requested over DDS" up4.log || fail "the launcher did not log the down request"
for key in m1.slip_events m1.contact_lost m1.failovers m1.rejected_commands; do
  v=$(sed -n "s|^$key=||p" live.sum)
  [ "$v" = 0 ] || fail "$key = $v in the secured run"
done

echo "== 4. a packet capture of a secured run over UDP holds no sensor values"
# Without root the capture part cannot run: the test reports itself skipped (ctest SKIP_RETURN_CODE 77), not passed.
[ "$(id -u)" -eq 0 ] || { echo "SKIP: the capture needs root (a raw socket on lo); CI runs as root"; trap - EXIT; exit 77; }
for mode in plain secure; do
  d4=$((base + 3)); [ "$mode" = secure ] && d4=$((base + 4))
  deploy "cap-$mode" "$d4" lockstep udp "$src/config/scenarios/paper.yaml" $([ "$mode" = secure ] && echo yes || echo no) > "cap-$mode.yaml"
  [ "$mode" = secure ] && { "$bin/tandem" keys "cap-$mode.yaml" > /dev/null 2>&1 || fail "tandem keys cap"; }
  # The capture covers the whole run, a start-up repair included (the launcher restarts a module that did not
  # come up; docs/security.md).
  python3 "$src/tests/security/capture.py" capture lo "cap-$mode.bin" 150 > "cap-$mode.txt" &
  cap=$!; pids+=($cap)
  sleep 0.5
  rc=0; "$bin/tandem" up "cap-$mode.yaml" --summary "cap-$mode.sum" > "up-cap-$mode.log" 2>&1 || rc=$?
  kill "$cap" 2>/dev/null || true; wait "$cap" || true; pids=()
  [ "$rc" -eq 0 ] || { tail -20 "up-cap-$mode.log"; fail "capture run ($mode)"; }
  echo "cap-$mode.yaml: start-up repairs $(sed -n 's/^start_repairs=//p' "cap-$mode.sum")"
  grep -q "^rtps_frames=[1-9]" "cap-$mode.txt" || { cat "cap-$mode.txt"; fail "the capture of the $mode run saw no RTPS frames"; }
  found=$(python3 "$src/tests/security/capture.py" find "cap-$mode.bin" 1000 1999 0.001)
  echo "$mode run over UDP: $(cat "cap-$mode.txt"), $found"
  n=$(echo "$found" | sed 's/.*sensor_times_found=\([0-9]*\).*/\1/')
  if [ "$mode" = plain ]; then
    [ "$n" -ge 980 ] || fail "the plain capture misses the sensor values ($found): the check would prove nothing"
  else
    [ "$n" -eq 0 ] || fail "the secured capture holds $n sensor values in clear"
  fi
done
trap - EXIT
echo "PASS"
