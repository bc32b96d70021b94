#!/usr/bin/env bash
# Issue 22's figures on a lent GPU machine, from a bundle of scripts/gpu_bundle.sh (TARGETS must include
# diskchungs bench_step_loop and the test executables named below):
#   tests     the GPU tests of test_optim, test_render, test_mapping (and test_pipeline, test_residency if bundled)
#   memcheck  compute-sanitizer memcheck on the pruning, Adam, sky and rasterizer tests
#   b200 b1m  bench_step_loop on a street grown to ~200 k and ~1 M Gaussians a step
#   kitti     run on kitti_seq1, 30 steps per keyframe; kmap: bench_step_loop on that map
#   kold      the same run with the keyframe rule of the issue's "before" and 200 final steps
#   street    the 1 km street at 72 km/h (anytime, --speed 2)
# Env: WHAT (default all of the above), BUNDLE (default .gpu/rt), DATA (folder holding kitti_seq1, default
# .gpu/data), WORK (default /tmp/w), DENSITY (b1m's sampler density, default 10), SEGMENTS (b200's and b1m's
# segment_entries timed after the default on the same map, default 0,512,0,512), OUT (step.tgz written there).
# Kernel by kernel: ncu --metrics gpu__time_duration.sum -k regex:'forward|backward|ssim|adam' \
#   --launch-skip 400 --launch-count 40 bench_step_loop --map WORK/k30 --steps 30
set -uo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bundle=${BUNDLE:-$root/.gpu/rt}
data=${DATA:-$root/.gpu/data}
export LD_LIBRARY_PATH=$bundle/lib PATH=$PATH:/usr/local/cuda/bin
bin=$bundle/bin
w=${WORK:-/tmp/w}; mkdir -p "$w"
SEGMENTS=${SEGMENTS:-0,512,0,512}
nvidia-smi --query-gpu=name --format=csv,noheader | tee "$w/device.txt"
printf 'mapper:\n  keyframe_every: 1\n  keyframe_parallax: 0\n  keyframe_rotation_deg: 0\n' >"$w/old_kf.yaml"
kitti=(--dataset "kitti:$data/kitti_seq1" --poses gt --iterations 30 --device cuda)
for x in ${WHAT:-tests memcheck b200 b1m kitti kmap kold street}; do
  t0=$SECONDS
  case $x in
  tests)
    for t in test_optim test_render test_mapping test_pipeline test_residency; do
      [[ -x $bin/$t ]] || continue
      "$bin/$t" --gtest_filter='Cuda*:*Gpu*:*GPU*:*Device*' >"$w/$t.log" 2>&1
      echo "$t rc $?: $(grep -a '^\[  PASSED\|^\[  FAILED' "$w/$t.log" | tr '\n' ' ')"
    done ;;
  memcheck)
    compute-sanitizer --tool memcheck --leak-check full --error-exitcode 3 "$bin/test_optim" \
      --gtest_filter='CudaPrune*:CudaAdam*:CudaLoss*' >"$w/memcheck_optim.log" 2>&1
    echo "memcheck optim rc $?"
    compute-sanitizer --tool memcheck --leak-check full --error-exitcode 3 "$bin/test_render" \
      --gtest_filter='CudaSky*:CudaRaster*' >"$w/memcheck_render.log" 2>&1
    echo "memcheck render rc $?" ;;
  b200) "$bin/bench_step_loop" --visible 200000 --steps 500 --segments "$SEGMENTS" --json "$w/step_200k.json" \
          >"$w/step_200k.log" 2>&1 ;;
  b1m) "$bin/bench_step_loop" --visible 1000000 --steps 300 --density "${DENSITY:-10}" --segments "$SEGMENTS" \
         --json "$w/step_1m.json" >"$w/step_1m.log" 2>&1 ;;
  kitti) rm -rf "$w/k30"; "$bin/diskchungs" run "${kitti[@]}" --out "$w/k30" >"$w/kitti30.log" 2>&1 ;;
  kmap) "$bin/bench_step_loop" --map "$w/k30" --steps 500 --json "$w/step_kitti.json" >"$w/step_kitti.log" 2>&1 ;;
  kold) rm -rf "$w/kold"; "$bin/diskchungs" run "${kitti[@]}" --final-iterations 200 --config "$w/old_kf.yaml" \
          --out "$w/kold" >"$w/kold.log" 2>&1 ;;
  street) rm -rf "$w/s1k"; "$bin/diskchungs" run --dataset synth-street:length=1000,width=620,height=188 --poses gt \
            --pacing anytime --speed 2 --device cuda --out "$w/s1k" >"$w/street1k.log" 2>&1 ;;
  *) echo "step_loop.sh: unknown item $x"; exit 2 ;;
  esac
  echo "$x: rc $? in $((SECONDS - t0)) s"
done
for r in k30 kold s1k; do
  [[ -f $w/$r/report.json ]] || continue
  python3 -c "
import json; r = json.load(open('$w/$r/report.json'))
print('$r', 'steps', r['iterations'], 'keyframes', r.get('keyframes'), 'fps', round(r['time']['processing_fps'], 2),
      'held-out', round(r['held_out']['mean_psnr'], 2), 'step_ms', {k: round(v, 3) for k, v in r['step_ms'].items()})"
done
for f in "$w"/step_*.log; do [[ -f $f ]] && { echo "== $f"; grep -av 'keyframe [0-9]' "$f" | tail -n 32; }; done
[[ -n ${OUT:-} ]] && (cd "$w" && tar czf "$OUT/step.tgz" ./*.log ./*.json ./*/report.json 2>/dev/null)
exit 0
