#!/usr/bin/env bash
# Runs every benchmark in one go and prints each against its target as a ratio, so numbers
# taken on a noisy machine are compared within one run (README "Performance").
# Usage: bench/run.sh [BUILD_DIR]   (default: build; build it first: cmake --build build)
#
#        bench/run.sh --against REV [--rounds N] [--pin CPU] [--only REGEX] [BUILD_DIR]
# builds REV's benchmarks in a temporary git worktree (same CMake options, ccache), then runs
# this tree's and REV's binaries alternately, N rounds (default 3), and prints per benchmark the
# medians of both and the ratio REV/this of the time per iteration (> 1: this tree is faster),
# the peak RSS of both processes (/usr/bin/time) and, where both report it, the ratio of every
# shared counter. --pin CPU runs both on one core (taskset), --only keeps the binaries whose
# target name matches. REV's worktree and build stay in build-against-REV (git-ignored) for
# the next run. The README's "vs 5518d93" column is `--against 5518d93`.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)

# The comparable benchmark binaries: target name and path under the build directory. The
# thermal benchmark (minutes) and the CAN ones (user-mode Linux) stay out of --against.
against_targets=(
  "imubench_nav_bench bench/nav/imubench_nav_bench"
  "imubench_calib_bench bench/calib/imubench_calib_bench"
  "imubench_bench_indirect_calibration bench/calibration/imubench_bench_indirect_calibration"
  "imubench_bench_explain bench/calibration/imubench_bench_explain"
  "imubench_daemon_bench bench/daemon/imubench_daemon_bench"
  "imubench_store_bench bench/daemon/imubench_store_bench"
  "imubench_online_engine_bench bench/daemon/imubench_online_engine_bench"
)

against() {  # rev, rounds, pin, only, build
  local rev=$1 rounds=$2 pin=$3 only=$4 build=$5
  local sha
  sha=$(git -C "$here" rev-parse --short "$rev^{commit}")
  # REV's worktree and build are kept for the next run against it (builds are the cost), next
  # to this tree's build directories so ccache (base_dir) shares objects between the trees;
  # remove with: git worktree remove --force DIR
  local wt=$here/build-against-$sha
  if [[ ! -d $wt/.git && ! -f $wt/.git ]]; then
    git -C "$here" worktree add --detach "$wt" "$sha" >/dev/null
  fi
  wt=$(cd "$wt" && pwd -P)  # a symlink to an existing REV build works too
  local tmp
  tmp=$(mktemp -d "${TMPDIR:-/tmp}/imubench-against-run.XXXXXX")
  echo "bench/run.sh: results in $tmp" >&2
  cmake -S "$wt" -B "$wt/build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_COMPILER_LAUNCHER=ccache >"$tmp/configure.log" ||
    { cat "$tmp/configure.log" >&2; return 1; }
  local names=() t n p
  for t in "${against_targets[@]}"; do
    read -r n p <<<"$t"
    [[ -z $only || $n =~ $only ]] && names+=("$n $p")
  done
  local targets=()
  for t in "${names[@]}"; do targets+=("${t%% *}"); done
  echo "bench/run.sh: building ${#targets[@]} benchmark targets of $sha in $wt and of this tree in $build" >&2
  cmake --build "$wt/build" -j2 --target "${targets[@]}" -- -k 0 >"$tmp/build-rev.log" 2>&1 ||
    echo "bench/run.sh: some of $sha's targets did not build (see below)" >&2
  cmake --build "$build" -j2 --target "${targets[@]}" >"$tmp/build-this.log" 2>&1 ||
    { tail -20 "$tmp/build-this.log" >&2; return 1; }
  local runner=()
  [[ -n $pin ]] && runner=(taskset -c "$pin")
  local r side bin out
  for ((r = 1; r <= rounds; ++r)); do
    for t in "${names[@]}"; do
      read -r n p <<<"$t"
      for side in this rev; do
        [[ $side == this ]] && bin=$build/$p || bin=$wt/build/$p
        out=$tmp/$side.$n.$r
        if [[ ! -x $bin ]]; then
          echo "bench/run.sh: $side: $n not built" >&2
          continue
        fi
        echo "round $r/$rounds: $side $n" >&2
        /usr/bin/time -f "%e %U %S %M" -o "$out.time" "${runner[@]}" "$bin" \
          --benchmark_format=json --benchmark_out="$out.json" --benchmark_out_format=json \
          >/dev/null 2>"$out.err" || echo "bench/run.sh: $side $n failed (rc $?)" >&2
      done
    done
  done
  python3 "$here/bench/compare.py" "$tmp" "$sha" "$rounds" "${targets[@]}"
}

if [[ ${1:-} == --against ]]; then
  rev=${2:?"--against needs a revision"}
  shift 2
  rounds=3 pin="" only=""
  while [[ $# -gt 0 && $1 == --* ]]; do
    case $1 in
      --rounds) rounds=$2 ;;
      --pin) pin=$2 ;;
      --only) only=$2 ;;
      *) echo "bench/run.sh: unknown option $1" >&2; exit 2 ;;
    esac
    shift 2
  done
  build=$(cd "${1:-$here/build}" && pwd)
  against "$rev" "$rounds" "$pin" "$only" "$build"
  exit
fi

build=${1:-$here/build}
run() {  # name, binary, extra args...
  local name=$1 bin=$2
  shift 2
  echo "== $name =="
  if [[ ! -x $bin ]]; then
    echo "bench/run.sh: $bin is not built" >&2
    return 1
  fi
  "$bin" "$@"
}
run "strapdown update (target >= 5 M samples/s, counter x_5M_target)" \
  "$build/bench/nav/imubench_nav_bench"
run "simulator (target >= 2 M samples/s)" "$build/bench/calib/imubench_calib_bench"
run "indirect calibration of a 2 kHz 12-run recording (target < 10 s)" \
  "$build/bench/calibration/imubench_bench_indirect_calibration"
run "imubench explain of a 2 kHz 12-run recording: baseline calibration + analysis (target < 10 s, counter fraction_of_10s_target; baseline_s / bins_s / analysis_s / json_s: where the time goes)" \
  "$build/bench/calibration/imubench_bench_explain"
run "reading a 1 h, 2 kHz imubench-csv/1 recording (target < 10 s; cpu_s: the whole process's CPU per read)" \
  "$build/bench/daemon/imubench_daemon_bench"
run "SQLite store: appending a 2 kHz IMU + 100 Hz table run (target >= 10x real time, counter x_realtime)" \
  "$build/bench/daemon/imubench_store_bench"
run "online engine on the loop per IMU sample at 2 kHz (target < 5 % of one core, counter x_target)" \
  "$build/bench/daemon/imubench_online_engine_bench"
run "thermal calibration over -40..+60 degC: continuous-ramp vs soak-point plan (target: ramp chamber time <= 0.5 x soak, both within 2x noise floor and 5 % bias tempco; exit 1 when not)" \
  "$build/bench/calibration/imubench_bench_thermal" || true
run "lab mirror into a throwaway PostgreSQL: items/s, samples/s, 20 benches at 2 kHz in real time (target 42,020 rows/s into one database; ratios > 1 meet it)" \
  "$build/bench/lab/imubench_lab_bench" || true
echo "== peak memory of imubench calibrate and explain on 1 h at 2 kHz (target < 1 GiB each) =="
"$here/bench/peak_rss_1h.sh" "$build" || true
"$here/bench/can_bench.sh" "$build"
