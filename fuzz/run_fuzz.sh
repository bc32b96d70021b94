#!/usr/bin/env bash
# Runs the libFuzzer targets built in build-fuzz (README "Fuzzing"), each for a bounded time over
# its seed corpus in fuzz/corpus/TARGET, and prints per target the executions, the corpus it ended
# with and its findings. Exit status 1 when any target found something (crash, sanitizer report,
# uncaught exception, timeout, more than 1 GB), 2 on a usage error, 77 with --skip-missing when the
# targets are not built (ctest counts that as skipped).
#
#   fuzz/run_fuzz.sh [--time SECONDS] [--build DIR] [--keep DIR] [--skip-missing] [TARGET...]
#
# New inputs go to a scratch corpus (kept under --keep DIR/TARGET when given), never into the seeds;
# a finding's input is written to $FINDINGS (default: fuzz-findings/ in the current folder).
set -uo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
seconds=20
build=$root/build-fuzz
keep=""
skip_missing=0
targets=()
while [ $# -gt 0 ]; do
  case $1 in
    --time) seconds=$2; shift 2 ;;
    --build) build=$2; shift 2 ;;
    --keep) keep=$2; shift 2 ;;
    --skip-missing) skip_missing=1; shift ;;
    -h|--help) sed -n '2,12p' "$0"; exit 0 ;;
    -*) echo "run_fuzz.sh: unknown option $1" >&2; exit 2 ;;
    *) targets+=("$1"); shift ;;
  esac
done

listing=$build/fuzz_targets.txt
if [ ! -f "$listing" ]; then
  echo "run_fuzz.sh: no fuzz targets in $build (scripts/setup.sh builds them when clang is installed)" >&2
  [ $skip_missing = 1 ] && exit 77
  exit 2
fi
[ ${#targets[@]} -gt 0 ] || mapfile -t targets < "$listing"
findings_dir=${FINDINGS:-$PWD/fuzz-findings}
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

printf '%-14s %12s %8s %8s %s\n' target executions seconds corpus findings
failed=0
for t in "${targets[@]}"; do
  exe=$build/fuzz/${t}_fuzz
  seeds=$root/fuzz/corpus/$t
  if [ ! -x "$exe" ] || [ ! -d "$seeds" ]; then
    echo "run_fuzz.sh: no target '$t' (built: $(tr '\n' ' ' < "$listing"))" >&2
    exit 2
  fi
  work=${keep:+$keep/$t}
  work=${work:-$scratch/$t}
  mkdir -p "$work" "$findings_dir/$t"
  log=$scratch/$t.log
  marker=$scratch/$t.start
  touch "$marker"
  start=$(date +%s)
  # The limits make a huge allocation a finding; -timeout catches an input that hangs a parser.
  "$exe" "$work" "$seeds" -max_total_time="$seconds" -rss_limit_mb=1024 -malloc_limit_mb=1024 -timeout=10 \
    -print_final_stats=1 -artifact_prefix="$findings_dir/$t/" > "$log" 2>&1
  rc=$?
  elapsed=$(( $(date +%s) - start ))
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  units=$(find "$work" "$seeds" -type f | wc -l)
  found=$(find "$findings_dir/$t" -type f -newer "$marker" | wc -l)
  if [ $rc != 0 ] || [ "$found" != 0 ]; then
    failed=1
    [ "$found" != 0 ] || found="exit $rc"
    echo "--- $t: last lines of its log ($findings_dir/$t/ holds the input)" >&2
    tail -n 40 "$log" >&2
  fi
  printf '%-14s %12s %8s %8s %s\n' "$t" "${execs:-?}" "$elapsed" "$units" "$found"
  rmdir "$findings_dir/$t" 2>/dev/null
done
rmdir "$findings_dir" 2>/dev/null
exit $failed
