#!/usr/bin/env bash
# The two static checks CI runs after the build (tools/test.sh) catch a planted violation and
# pass without it, using the project's own scripts and .clang-tidy:
#  - tools/function_size_check.py: a copy of a project source with a function of 81 body
#    lines fails, naming file:line and the function; 80 lines pass; an allowlisted function
#    that grows, and an allowlist entry that no longer matches, fail;
#  - tools/tidy_check.py: a file with a bugprone-use-after-move finding fails naming
#    file:line and the check, in the changed-since-base mode CI uses and for a named file;
#    the clean version passes; a change of #include lines only is not a change; more TUs
#    than the cap and a base missing from the clone fail with a message saying so; a finding
#    in an unchanged header a changed TU includes is listed, not counted, until it changes.
# Usage: static_checks_planted.sh SOURCE_DIR
set -euo pipefail
src=$(cd "${1:?usage: static_checks_planted.sh SOURCE_DIR}" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
size_check=(python3 "$src/tools/function_size_check.py")
tidy_check=(python3 "$src/tools/tidy_check.py")

expect_fail() {  # expect_fail WHAT PATTERN... -- COMMAND...: fails unless COMMAND fails
  local what=$1 patterns=() out rc=0
  shift
  while [[ $1 != -- ]]; do patterns+=("$1"); shift; done
  shift
  out=$("$@" 2>&1) || rc=$?
  if ((rc == 0)); then
    printf 'FAIL: %s: the check passed:\n%s\n' "$what" "$out" >&2; exit 1
  fi
  for p in "${patterns[@]}"; do
    if ! grep -qE -- "$p" <<<"$out"; then
      printf 'FAIL: %s: output lacks /%s/:\n%s\n' "$what" "$p" "$out" >&2; exit 1
    fi
  done
  echo "ok: $what fails: $(grep -E -- "${patterns[0]}" <<<"$out" | head -1)"
}

expect_pass() {  # expect_pass WHAT COMMAND...
  local what=$1 out
  shift
  if ! out=$("$@" 2>&1); then
    printf 'FAIL: %s: the check failed:\n%s\n' "$what" "$out" >&2; exit 1
  fi
  echo "ok: $what passes"
}

# A function of N body lines (lines strictly between its braces).
long_function() {  # long_function NAME N
  echo "int $1(int x) {"
  for ((i = 1; i <= $2; ++i)); do echo "  x += $i;"; done
  echo "}"
}

# --- function size: a copy of a real source, then the planted function appended ---
mkdir -p "$tmp/size/nav"
cp "$src/nav/earth.cpp" "$tmp/size/nav/earth.cpp"
copy=$tmp/size/nav/earth.cpp
expect_pass "size check on an unplanted copy of nav/earth.cpp" "${size_check[@]}" "$copy"
line=$(($(wc -l <"$copy") + 1))
long_function plantedLong 81 >>"$copy"
expect_fail "size check on a planted 81-line function" "earth\.cpp:$line: function plantedLong has 81 lines" \
  -- "${size_check[@]}" "$copy"
cp "$src/nav/earth.cpp" "$copy"
long_function plantedLong 80 >>"$copy"
expect_pass "size check on an 80-line function" "${size_check[@]}" "$copy"

# The allowlist in a tree of its own: a listed function may not grow, a stale entry fails.
printf 'earth.cpp plantedLong 85  planted for the test\n' >"$tmp/size/allow.txt"
cp "$src/nav/earth.cpp" "$copy"
long_function plantedLong 85 >>"$copy"
expect_pass "size check on an allowlisted 85-line function" \
  "${size_check[@]}" --root "$tmp/size" --allowlist "$tmp/size/allow.txt"
cp "$src/nav/earth.cpp" "$copy"
long_function plantedLong 86 >>"$copy"
expect_fail "size check on an allowlisted function that grew" "function plantedLong has 86 lines, more than the 85" \
  -- "${size_check[@]}" --root "$tmp/size" --allowlist "$tmp/size/allow.txt"
cp "$src/nav/earth.cpp" "$copy"
expect_fail "size check on a stale allowlist entry" "allowlisted function plantedLong in earth.cpp is gone" \
  -- "${size_check[@]}" --root "$tmp/size" --allowlist "$tmp/size/allow.txt"

# --- clang-tidy: a git tree of its own with the project's .clang-tidy and a compile database ---
t=$tmp/tidy
mkdir -p "$t/tools" "$t/nav"
cp "$src/.clang-tidy" "$t/.clang-tidy"
cat >"$t/nav/planted.cpp" <<'EOF'
#include <string>
#include <utility>

int planted() {
  std::string a = "imu";
  std::string b = std::move(a);
  return static_cast<int>(b.size());
}
EOF
printf '[{"directory": "%s", "file": "%s", "command": "c++ -std=gnu++20 -Wall -c %s"}]\n' \
  "$t" "$t/nav/planted.cpp" "$t/nav/planted.cpp" >"$t/compile_commands.json"
git -C "$t" init -q
git -C "$t" -c user.name=t -c user.email=t@t add -A
git -C "$t" -c user.name=t -c user.email=t@t commit -qm base
git -C "$t" rev-parse HEAD >"$t/tools/tidy_base.txt"
expect_pass "clang-tidy on the clean file" "${tidy_check[@]}" --root "$t" -p "$t" nav/planted.cpp
sed -i 's/#include <utility>/#include <utility>  \/\/ std::move/' "$t/nav/planted.cpp"
expect_pass "clang-tidy since the base after an #include-only change" \
  "${tidy_check[@]}" --root "$t" -p "$t"
sed -i 's/return static_cast<int>(b.size());/return static_cast<int>(a.size() + b.size());/' \
  "$t/nav/planted.cpp"
expect_fail "clang-tidy since the base on a planted use after move" \
  "nav/planted\.cpp:7:[0-9]+: (error|warning): 'a' used after it was moved \[bugprone-use-after-move" \
  "1 project source\(s\) changed" -- "${tidy_check[@]}" --root "$t" -p "$t"
expect_fail "clang-tidy over the TU cap (the CI time budget)" "1 TUs to check, more than --max-tus 0" \
  -- "${tidy_check[@]}" --root "$t" -p "$t" --max-tus 0
expect_fail "clang-tidy since a base the clone lacks" "is not in this clone's history" \
  -- "${tidy_check[@]}" --root "$t" -p "$t" --base 0123456789abcdef0123456789abcdef01234567
expect_fail "clang-tidy on the planted file named" "planted\.cpp:7:.*bugprone-use-after-move" \
  -- "${tidy_check[@]}" --root "$t" -p "$t" nav/planted.cpp
# A shallow clone without the base (whether CI clones shallow is CI's choice): said, not failed.
git -C "$t" add -A && git -C "$t" -c user.name=t -c user.email=t@t commit -qm next
git clone -q --depth 1 "file://$t" "$t.shallow"
if ! out=$("${tidy_check[@]}" --root "$t.shallow" -p "$t" 2>&1) ||
  ! grep -q "NOT RUN: this clone is shallow" <<<"$out"; then
  printf 'FAIL: clang-tidy in a shallow clone: %s\n' "$out" >&2; rm -rf "$t.shallow"; exit 1
fi
rm -rf "$t.shallow"
echo "ok: clang-tidy in a shallow clone says it did not run"
# A finding in an unchanged header that a changed TU includes is listed, not counted (not the
# change's to fix); once the header itself changes, it counts.
h=$tmp/tidy_header
mkdir -p "$h/tools" "$h/nav"
cp "$src/.clang-tidy" "$h/.clang-tidy"
cat >"$h/nav/old.h" <<'EOF'
#pragma once
#include <string>
#include <utility>

inline int oldHeader() {
  std::string a = "imu";
  std::string b = std::move(a);
  return static_cast<int>(a.size() + b.size());
}
EOF
printf '#include "nav/old.h"\n\nint user() { return oldHeader(); }\n' >"$h/nav/user.cpp"
printf '[{"directory": "%s", "file": "%s", "command": "c++ -std=gnu++20 -I%s -c %s"}]\n' \
  "$h" "$h/nav/user.cpp" "$h" "$h/nav/user.cpp" >"$h/compile_commands.json"
git -C "$h" init -q
git -C "$h" -c user.name=t -c user.email=t@t add -A
git -C "$h" -c user.name=t -c user.email=t@t commit -qm base
git -C "$h" rev-parse HEAD >"$h/tools/tidy_base.txt"
printf 'int userToo() { return 2; }\n' >>"$h/nav/user.cpp"
if ! out=$("${tidy_check[@]}" --root "$h" -p "$h" 2>&1) ||
  ! grep -q "in unchanged headers these TUs include, not counted" <<<"$out" ||
  ! grep -q "nav/old.h:8:.*bugprone-use-after-move" <<<"$out"; then
  printf 'FAIL: clang-tidy with a finding in an unchanged header: %s\n' "$out" >&2; exit 1
fi
echo "ok: clang-tidy lists an unchanged header's finding without counting it"
sed -i 's/"imu"/"imu2"/' "$h/nav/old.h"
expect_fail "clang-tidy once that header changed" "nav/old\.h:8:.*bugprone-use-after-move" \
  -- "${tidy_check[@]}" --root "$h" -p "$h"
echo "static checks: every planted violation caught, every clean version passed"
