#!/usr/bin/env bash
# Runs the GPU tests (GoogleTest, JSON reports), compute-sanitizer memcheck on the CUDA tests and the
# GPU benchmarks from a bundle made by scripts/gpu_bundle.sh, and writes everything to OUTDIR:
#   run.log          all output, in order
#   memcheck.log     compute-sanitizer output
#   gtest_<exe>.json GoogleTest reports
#   bench_cuda_rasterizer.json
#   results.json     summary: pass/fail per step, exit codes, device
#   map_<name>_report.json, map_<name>_timeline.csv   mapper runs (only with MAP_DATA)
# (at most 8 files, flat, so the lent GPU machine hands all of them back: with MAP_DATA, bundle at
# most one test executable and set SKIP_BENCH=1 SKIP_MEMCHECK=1).
# Usage: scripts/gpu_run.sh OUTDIR
# Env:   BUNDLE (default .gpu/bundle), GTEST_FILTER (default Cuda*), SKIP_MEMCHECK=1, SKIP_BENCH=1,
#        BENCH_ARGS (extra arguments for bench_cuda_rasterizer, e.g. "--cases kitti_1.5M"),
#        MAP_DATA (a KITTI sequence folder: runs `diskchungs run --device cuda` on it with ground-truth
#        poses at full resolution, as the CPU mapper run of bench/README.md, once with the default
#        budget ("full") and once with MAP_SMALL_ARGS ("budget", default --budget 50000 --chunk-size 5)),
#        MAP_ARGS (extra arguments for both runs; default --final-iterations 200)
set -uo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=${1:?usage: gpu_run.sh OUTDIR}
bundle=${BUNDLE:-$root/.gpu/bundle}
filter=${GTEST_FILTER:-Cuda*}
mkdir -p "$out"
log="$out/run.log"
: >"$log"
[[ -d "$bundle/bin" ]] || { echo "gpu_run: no bundle at $bundle (run scripts/gpu_bundle.sh, carry .gpu)" | tee -a "$log"; exit 1; }
export LD_LIBRARY_PATH="$bundle/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export PATH="$PATH:/usr/local/cuda/bin"

say() { echo "== $*" | tee -a "$log"; }
steps=()
record() { steps+=("{\"step\": \"$1\", \"exit_code\": $2}"); }

say "bundle: $(tr '\n' ';' <"$bundle/MANIFEST")"
say "host: $(uname -n) $(date -u +%FT%TZ)"
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv >>"$log" 2>&1
device=$(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | head -n 1)

if [[ -x "$bundle/bin/diskchungs" ]]; then
  say "diskchungs info"
  "$bundle/bin/diskchungs" info >>"$log" 2>&1
  record diskchungs_info $?
fi

for exe in "$bundle"/bin/test_*; do
  name=$(basename "$exe")
  say "$name --gtest_filter=$filter"
  "$exe" --gtest_filter="$filter" --gtest_output="json:$out/gtest_$name.json" >>"$log" 2>&1
  record "$name" $?
done

if [[ "${SKIP_MEMCHECK:-0}" != 1 ]]; then
  sanitizer=$(command -v compute-sanitizer || true)
  if [[ -z "$sanitizer" ]]; then
    say "compute-sanitizer not found"
    record memcheck 127
  else
    : >"$out/memcheck.log"
    for exe in "$bundle"/bin/test_*; do
      name=$(basename "$exe")
      # An executable without matching tests makes no CUDA call, which the sanitizer reports as an error.
      "$exe" --gtest_list_tests --gtest_filter="$filter" | grep -q '^  ' || continue
      say "memcheck $name"
      "$sanitizer" --tool memcheck --leak-check full --error-exitcode 3 "$exe" --gtest_filter="$filter" \
        >>"$out/memcheck.log" 2>&1
      rc=$?
      tail -n 3 "$out/memcheck.log" | tee -a "$log"
      record "memcheck_$name" $rc
    done
  fi
fi

if [[ "${SKIP_BENCH:-0}" != 1 && -x "$bundle/bin/bench_cuda_rasterizer" ]]; then
  say "bench_cuda_rasterizer ${BENCH_ARGS:-}"
  # shellcheck disable=SC2086
  "$bundle/bin/bench_cuda_rasterizer" --json "$out/bench_cuda_rasterizer.json" ${BENCH_ARGS:-} 2>&1 | tee -a "$log"
  record bench_cuda_rasterizer "${PIPESTATUS[0]}"
fi

if [[ -n "${MAP_DATA:-}" && -x "$bundle/bin/diskchungs" ]]; then
  maps=$(mktemp -d)
  for name in full budget; do
    extra=""
    [[ $name == budget ]] && extra=${MAP_SMALL_ARGS:---budget 50000 --chunk-size 5}
    say "diskchungs run --device cuda ($name) ${MAP_ARGS:---final-iterations 200} $extra"
    # shellcheck disable=SC2086
    "$bundle/bin/diskchungs" run --device cuda --dataset "kitti:$MAP_DATA" --poses gt --out "$maps/$name" \
      ${MAP_ARGS:---final-iterations 200} $extra >>"$log" 2>&1
    rc=$?
    record "map_$name" $rc
    cp "$maps/$name/report.json" "$out/map_${name}_report.json" 2>/dev/null
    cp "$maps/$name/timeline.csv" "$out/map_${name}_timeline.csv" 2>/dev/null
    tail -n 2 "$log"
  done
  rm -rf "$maps"
fi

failed=0
for s in "${steps[@]}"; do [[ "$s" == *'"exit_code": 0}' ]] || failed=1; done
{
  echo "{"
  echo "  \"device\": \"$device\","
  echo "  \"date\": \"$(date -u +%FT%TZ)\","
  echo "  \"bundle\": \"$(head -n 1 "$bundle/MANIFEST")\","
  echo "  \"ok\": $([[ $failed == 0 ]] && echo true || echo false),"
  echo "  \"steps\": ["
  for i in "${!steps[@]}"; do
    sep=","
    [[ $i == $((${#steps[@]} - 1)) ]] && sep=""
    echo "    ${steps[$i]}$sep"
  done
  echo "  ]"
  echo "}"
} >"$out/results.json"
cat "$out/results.json" | tee -a "$log"
exit $failed
