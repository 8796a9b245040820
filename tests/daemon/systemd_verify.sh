#!/usr/bin/env bash
# Runs `systemd-analyze verify` on the units in systemd/ and fails on any complaint (verify
# exits 0 on many warnings, so its output must be empty). imubenchd is not installed where
# tests run, and verify refuses a missing ExecStart binary: the daemon's ExecStart is pointed
# at /bin/true in a temporary copy. Fails (never skips) when systemd-analyze is missing:
# tools/install-deps.sh installs the systemd package that provides it.
set -euo pipefail
src=${1:?usage: systemd_verify.sh SYSTEMD_UNIT_DIR}
command -v systemd-analyze >/dev/null || {
  echo "systemd-analyze not found (Debian package: systemd)" >&2
  exit 1
}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
units=(imubenchd.service imubenchd.socket imubench-vcan.service)
for u in "${units[@]}"; do
  sed 's|^ExecStart=/usr/local/bin/imubenchd |ExecStart=/bin/true |' "$src/$u" >"$tmp/$u"
done
grep -q '^ExecStart=/bin/true ' "$tmp/imubenchd.service" || {
  echo "imubenchd.service: ExecStart=/usr/local/bin/imubenchd ... not found" >&2
  exit 1
}
out=$(cd "$tmp" && systemd-analyze verify --man=no "${units[@]/#/./}" 2>&1) || {
  printf 'systemd-analyze verify failed:\n%s\n' "$out" >&2
  exit 1
}
if [ -n "$out" ]; then
  printf 'systemd-analyze verify complained:\n%s\n' "$out" >&2
  exit 1
fi
echo "systemd-analyze verify: ${units[*]} clean"
