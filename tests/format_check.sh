#!/usr/bin/env bash
# Fails when any C++ source of the project is not formatted per .clang-format, naming the
# files (fix with: clang-format -i FILE). Run by ctest as style.clang_format.
set -euo pipefail
root=${1:?usage: format_check.sh SOURCE_DIR}
cd "$root"
mapfile -t files < <(find nav calib io plans drivers daemon tools tests bench \
  -type f \( -name '*.h' -o -name '*.cpp' \) | sort)
((${#files[@]})) || { echo "format_check: no sources found under $root" >&2; exit 1; }
bad=()
for f in "${files[@]}"; do
  clang-format --dry-run -Werror "$f" >/dev/null 2>&1 || bad+=("$f")
done
if ((${#bad[@]})); then
  printf 'not clang-format clean: %s\n' "${bad[@]}" >&2
  exit 1
fi
echo "clang-format: ${#files[@]} files clean"
