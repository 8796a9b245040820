#!/usr/bin/env bash
# Installs everything imubench needs to build, test and run, from Debian 12 packages.
# Idempotent; needs root (or sudo). Why each package is here: README.md "Dependencies".
set -euo pipefail
pkgs=(
  cmake ninja-build g++ pkg-config ccache git clang-format clang-tidy
  libeigen3-dev libceres-dev libmodbus-dev libsystemd-dev libtomlplusplus-dev
  nlohmann-json3-dev libfast-float-dev libcli11-dev libsqlite3-dev libssl-dev libgtest-dev libgmock-dev libbenchmark-dev
  libpq-dev postgresql-15 postgresql-client-15
  can-utils user-mode-linux kmod iproute2 mbpoll python3 python3-numpy python3-pymodbus socat systemd
  chromium-headless-shell
)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO=sudo
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
