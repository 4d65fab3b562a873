#!/usr/bin/env bash
# Mutation testing: applies each mutant of a list to the source tree, one at a time, rebuilds the
# test binaries that the mutant's tests live in, runs those tests, and reports whether a test failed
# (killed) or all passed (survived). Outside CI; see docs/testing.md, "Mutation testing".
#
#   scripts/mutate.sh [-b BUILD_DIR] [-l LIST] [-o REPORT.md] [-t TIMEOUT_S] [NAME_REGEX]
#
#   BUILD_DIR  a configured build tree whose test binaries were built once (default: build/test)
#   LIST       the mutant list (default: tests/mutants.txt); format in that file's header
#   REPORT.md  also write the table there (default: only stdout)
#   TIMEOUT_S  per-test timeout for ctest (default: 300)
#   NAME_REGEX run only the mutants whose name matches (grep -E)
#
# Each mutant edits its file in place; the original is restored by a trap on every exit path
# (including Ctrl-C), and the tree is checked to be clean of the mutation before the next one.
# Each mutant's build + test holds /tmp/swerve-build.lock (shared with the other worktrees).
# Exit status: 0 when the campaign ran (whatever survived), non-zero on a script or list error.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="$here/build/test"
list="$here/tests/mutants.txt"
report=""
timeout=300
lock=/tmp/swerve-build.lock
while getopts "b:l:o:t:h" opt; do
  case "$opt" in
    b) build_dir="$(cd "$OPTARG" && pwd)" ;;
    l) list="$OPTARG" ;;
    o) report="$OPTARG" ;;
    t) timeout="$OPTARG" ;;
    h) sed -n '2,16p' "$0"; exit 0 ;;
    *) exit 2 ;;
  esac
done
shift $((OPTIND - 1))
filter="${1:-.}"

[[ -f "$build_dir/CTestTestfile.cmake" ]] || { echo "mutate.sh: $build_dir is not a configured build tree" >&2; exit 2; }
[[ -f "$list" ]] || { echo "mutate.sh: no mutant list $list" >&2; exit 2; }
command -v python3 >/dev/null || { echo "mutate.sh: python3 is needed" >&2; exit 2; }

# apply FILE PATTERN REPLACEMENT OCCURRENCE: replace PATTERN (fixed string) on the one line that
# holds it (or on its OCCURRENCE-th line, 1-based) by REPLACEMENT; fail if that is ambiguous/absent.
apply() {
  python3 - "$@" <<'PY'
import sys
path, pattern, replacement, occurrence = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
lines = open(path).read().split("\n")
hits = [i for i, line in enumerate(lines) if pattern in line]
if occurrence == 0 and len(hits) != 1:
    sys.exit(f"{path}: pattern found on {len(hits)} lines (need exactly 1, or name an occurrence @N): {pattern}")
if occurrence > len(hits):
    sys.exit(f"{path}: pattern found on {len(hits)} lines, occurrence {occurrence} asked: {pattern}")
i = hits[0] if occurrence == 0 else hits[occurrence - 1]
if lines[i].count(pattern) != 1:
    sys.exit(f"{path}:{i + 1}: pattern occurs {lines[i].count(pattern)} times on the line: {pattern}")
lines[i] = lines[i].replace(pattern, replacement)
open(path, "w").write("\n".join(lines))
PY
}

# The test executables (target names) that hold the tests matching a ctest regex.
targets_for() {
  (cd "$build_dir" && ctest -N -R "$1" --show-only=json-v1) | python3 -c '
import json, os, sys
names = set()
for test in json.load(sys.stdin).get("tests", []):
    command = test.get("command") or []
    if command:
        names.add(os.path.basename(command[0]))
print(" ".join(sorted(names)))'
}

backup=""
target_file=""
restore() {
  if [[ -n "$backup" && -f "$backup" ]]; then
    cp "$backup" "$target_file"  # not -p: a fresh mtime makes the next build recompile it
    rm -f "$backup"
    backup=""
  fi
}
trap restore EXIT
trap 'restore; exit 130' INT TERM

rows=()
killed=0; survived=0; invalid=0; errors=0; total=0
log_dir="$(mktemp -d /tmp/swerve-mutate.XXXXXX)"
echo "logs: $log_dir"
while IFS= read -r line || [[ -n "$line" ]]; do
  [[ -z "${line// }" || "$line" =~ ^[[:space:]]*# ]] && continue
  # name | file[@N] | pattern | replacement | ctest regex   (fields separated by " | ")
  mapfile -t f < <(python3 -c 'import sys; [print(x.strip()) for x in sys.argv[1].split(" | ")]' "$line")
  if [[ ${#f[@]} -ne 5 ]]; then echo "mutate.sh: bad list line (need 5 fields): $line" >&2; errors=$((errors + 1)); continue; fi
  name="${f[0]}"; file="${f[1]}"; pattern="${f[2]}"; replacement="${f[3]}"; regex="${f[4]}"
  [[ "$replacement" == "<empty>" ]] && replacement=""
  [[ "$name" =~ $filter ]] || continue
  occurrence=0
  if [[ "$file" == *@* ]]; then occurrence="${file##*@}"; file="${file%@*}"; fi
  total=$((total + 1))
  target_file="$here/$file"
  if [[ ! -f "$target_file" ]]; then
    rows+=("| $name | \`$file\` | ERROR | no such file | |"); errors=$((errors + 1)); continue
  fi
  targets="$(targets_for "$regex")"
  if [[ -z "$targets" ]]; then
    rows+=("| $name | \`$file\` | ERROR | regex matches no test: \`$regex\` | |"); errors=$((errors + 1)); continue
  fi
  backup="$(mktemp /tmp/swerve-mutant-orig.XXXXXX)"
  cp -p "$target_file" "$backup"
  original_sum="$(sha1sum <"$target_file")"
  if ! apply "$target_file" "$pattern" "$replacement" "$occurrence" 2>"$log_dir/$name.apply"; then
    restore
    rows+=("| $name | \`$file\` | ERROR | $(tr '\n|' '  ' <"$log_dir/$name.apply") | |"); errors=$((errors + 1)); continue
  fi
  start=$SECONDS
  result=""; by=""
  # One lock for this mutant's build and tests, so other worktrees interleave between mutants.
  set +e
  flock "$lock" bash -c '
      cmake --build "$1" -j2 --target $2 >"$3.build" 2>&1 || exit 3
      cd "$1" && ctest -R "$4" -j2 --timeout "$5" --output-on-failure >"$3.test" 2>&1 || exit 4' \
      _ "$build_dir" "$targets" "$log_dir/$name" "$regex" "$timeout"
  status=$?
  set -e
  if [[ $status -eq 0 ]]; then
    result="**survived**"; by="$(grep -o '[0-9]*% tests passed.*' "$log_dir/$name.test" | head -1 || true)"
    survived=$((survived + 1))
  elif [[ $status -eq 3 ]]; then
    result="invalid"; by="does not build (see $log_dir/$name.build)"; invalid=$((invalid + 1))
  elif [[ $status -eq 4 ]]; then
    result="killed"
    by="$(sed -n 's/^[[:space:]]*[0-9]* - \(.*\) (\(Failed\|Timeout\|SEGFAULT\|Subprocess aborted\|Exception\|Child aborted\|Not Run\)).*/\1 (\2)/p' \
            "$log_dir/$name.test" | head -3 | paste -sd ';' - | sed 's/;/; /g' || true)"
    [[ -n "$by" ]] || by="ctest failed (see $log_dir/$name.test)"
    killed=$((killed + 1))
  else
    echo "mutate.sh: build/test step of $name ended with status $status" >&2; exit 2
  fi
  restore
  if [[ "$(sha1sum <"$target_file")" != "$original_sum" ]]; then
    # A mutant must never outlive its run.
    echo "mutate.sh: $file was not restored after $name" >&2; exit 2
  fi
  rows+=("| $name | \`$file\` | $result | $by | $((SECONDS - start)) s |")
  echo "${rows[-1]}"
done <"$list"

# Leave the build tree matching the unmutated sources.
flock "$lock" cmake --build "$build_dir" -j2 --target $(targets_for ".") >"$log_dir/final.build" 2>&1 || true

scored=$((killed + survived))
ratio="n/a"
if [[ $scored -gt 0 ]]; then ratio="$(python3 -c "print(f'{100 * $killed / $scored:.1f} %')")"; fi
{
  echo "| mutant | file | result | killed by (first failing tests) | time |"
  echo "| --- | --- | --- | --- | --- |"
  printf '%s\n' "${rows[@]}"
  echo
  echo "killed $killed, survived $survived, kill ratio $ratio (of $scored that built); $invalid did not build; $errors list errors"
} | tee ${report:+"$report"}
[[ $errors -eq 0 ]]
