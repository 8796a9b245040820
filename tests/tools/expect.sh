#!/bin/sh
# Runs a command and checks its exit code and (optionally) that its stdout+stderr match an
# extended regular expression.  Usage: expect.sh EXIT_CODE REGEX|- -- command args...
expected="$1"; regex="$2"; shift 3
out=$("$@" 2>&1); code=$?
printf '%s\n' "$out"
if [ "$code" != "$expected" ]; then
  echo "expect.sh: exit code $code, expected $expected" >&2; exit 1
fi
if [ "$regex" != "-" ] && ! printf '%s\n' "$out" | grep -Eq -- "$regex"; then
  echo "expect.sh: output does not match /$regex/" >&2; exit 1
fi
exit 0
