# Sourced by the scripts that drive imubench-virtual-bench from the outside (mbpoll, candump):
# start_virtual_bench BENCH ARGS... starts it with its output in $OUT/stdout and $OUT/stderr,
# stops it and removes $OUT on exit, and waits (deadline 30 s) for its "ready" line;
# fail MESSAGE prints the bench's output and exits 1.
OUT=$(mktemp -d)
PID=
cleanup() {
  if [ -n "$PID" ]; then
    kill "$PID" 2>/dev/null || true
    wait "$PID" 2>/dev/null || true
  fi
  rm -rf "$OUT"
}
trap cleanup EXIT
fail() {
  echo "FAIL: $*"
  echo "--- virtual bench stdout"; cat "$OUT/stdout"
  echo "--- virtual bench stderr"; cat "$OUT/stderr"
  exit 1
}
start_virtual_bench() {
  "$@" >"$OUT/stdout" 2>"$OUT/stderr" &
  PID=$!
  for _ in $(seq 300); do
    grep -q '^ready' "$OUT/stdout" && break
    kill -0 "$PID" 2>/dev/null || fail "virtual bench exited"
    sleep 0.1
  done
  grep -q '^ready' "$OUT/stdout" || fail "virtual bench not ready after 30 s"
}
