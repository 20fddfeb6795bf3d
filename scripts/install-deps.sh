#!/usr/bin/env bash
# Installs the Debian packages this project builds and runs with, only when some are missing.
# Safe to run repeatedly; needs root (or sudo) only when something must be installed.
# Usage: scripts/install-deps.sh [--tests]   (--tests: also what the test suite needs: Chromium for the report
# page checks, Cyclone DDS for the interop tests, python3 for the security test's packet capture, and Node.js
# with npm for the independent MCAP reader when no node is on the PATH, iproute2 for the multi-host test's network
# namespaces). openssl: `tandem keys`. civetweb and nlohmann-json: `tandem view` (HTTP and WebSocket, the
# Foxglove protocol's JSON). libcli11-dev: the role processes' command lines.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config
  libeigen3-dev
  libfastrtps-dev fastddsgen fastdds-tools
  libprotobuf-dev protobuf-compiler zlib1g-dev
  libyaml-cpp-dev
  libcli11-dev
  libcivetweb-dev nlohmann-json3-dev
  catch2
  openssl
)

if [ "${1:-}" = "--tests" ]; then
  PACKAGES+=(chromium cyclonedds-dev cyclonedds-tools python3 iproute2)
  if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then PACKAGES+=(nodejs npm); fi
fi

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

echo "install-deps: installing missing packages: ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "install-deps: need root to install: ${missing[*]}" >&2; exit 1
  fi
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
