#!/usr/bin/env bash
# Makes (or removes) "hosts" on this machine for trying a multi-host deployment: one Linux network namespace per
# host, each with a veth pair into a bridge, host i at SUBNET.i/24 (docs/multihost.md). Needs root.
#
#   scripts/netns-hosts.sh up   [PREFIX [SUBNET [HOST...]]]   default: tandem 10.77.0 a b c
#   scripts/netns-hosts.sh down [PREFIX [HOST...]]            kills what runs in them, removes them
#
# Namespaces are PREFIX-HOST (run a process on one with `ip netns exec PREFIX-a CMD`), the bridge PREFIXbr.
# deploy/three-hosts.yaml expects the defaults. Interface names are PREFIX + HOST + 0/1: keep PREFIX + HOST
# within 13 characters.
set -euo pipefail
usage() { sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//'; }
cmd=${1:-}
[ "$cmd" = up ] || [ "$cmd" = down ] || { usage; [ "$cmd" = --help ] || [ "$cmd" = -h ] && exit 0; exit 2; }
[ "$(id -u)" = 0 ] || { echo "netns-hosts: network namespaces need root" >&2; exit 1; }
p=${2:-tandem}
if [ "$cmd" = up ]; then
  net=${3:-10.77.0}
  shift $(( $# < 3 ? $# : 3 ))
  hosts=("$@"); [ ${#hosts[@]} -gt 0 ] || hosts=(a b c)
  [[ "$net" =~ ^[0-9]+\.[0-9]+\.[0-9]+$ ]] || { echo "netns-hosts: SUBNET is the first three numbers of an IPv4 address, e.g. 10.77.0; got '$net'" >&2; exit 2; }
  for h in "${hosts[@]}"; do
    [ ${#p} -le $((13 - ${#h})) ] || { echo "netns-hosts: '$p$h' is too long for an interface name (13 characters at most)" >&2; exit 2; }
    ! ip netns list | grep -qw "$p-$h" || { echo "netns-hosts: namespace $p-$h exists already ('$0 down $p' removes it)" >&2; exit 1; }
  done
  ip link add "${p}br" type bridge
  ip link set "${p}br" up
  i=1
  for h in "${hosts[@]}"; do
    ip netns add "$p-$h"
    ip link add "${p}${h}0" type veth peer name "${p}${h}1"
    ip link set "${p}${h}0" netns "$p-$h"
    ip link set "${p}${h}1" master "${p}br" up
    ip netns exec "$p-$h" ip link set lo up
    ip netns exec "$p-$h" ip addr add "$net.$i/24" dev "${p}${h}0"
    ip netns exec "$p-$h" ip link set "${p}${h}0" up
    echo "host $h: namespace $p-$h, address $net.$i (its link: ${p}${h}1; 'ip link set ${p}${h}1 down' cuts it)"
    i=$((i + 1))
  done
else
  shift $(( $# < 2 ? $# : 2 ))
  hosts=("$@")
  if [ ${#hosts[@]} -eq 0 ]; then
    mapfile -t hosts < <(ip netns list | awk '{print $1}' | grep "^$p-" | sed "s/^$p-//")
  fi
  for h in "${hosts[@]}"; do
    for q in $(ip netns pids "$p-$h" 2>/dev/null); do kill -9 "$q" 2>/dev/null || true; done
    ip netns del "$p-$h" 2>/dev/null || true
  done
  ip link del "${p}br" 2>/dev/null || true
  echo "removed ${#hosts[@]} host namespace(s) of $p"
fi
