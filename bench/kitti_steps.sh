#!/usr/bin/env bash
# Step throughput on real KITTI at full resolution (issue 22's measure), on a lent GPU machine:
# kitti_seq1 (51 frames, 1241x376), ground-truth poses, fixed pacing at 30 and 300 steps per keyframe,
# with the keyframe images kept in VRAM (the default) and uploaded every step
# (`mapper: {gpu_keyframe_cache_mb: 0}`). The cost of a step is the extra mapping time of the 300-step
# run over the 30-step one divided by its extra steps (ingestion and evaluation cancel out); report.json
# `step_ms` gives the optimiser thread's own breakdown.
# Env: BUNDLE (default .gpu/rt), DATA (folder holding kitti_seq1, default .gpu/data), WORK (default
# /tmp/ks), OUT (summary.json written there when set).
set -uo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bundle=${BUNDLE:-$root/.gpu/rt}
data=${DATA:-$root/.gpu/data}
work=${WORK:-/tmp/ks}
export LD_LIBRARY_PATH=$bundle/lib
bin=$bundle/bin/diskchungs
rm -rf "$work" && mkdir -p "$work"
printf 'mapper:\n  gpu_keyframe_cache_mb: 0\n' >"$work/no_cache.yaml"

run() {  # run NAME ITERATIONS [ARGS...]
  local name=$1 it=$2
  shift 2
  # --preset outdoor is what `auto` picks for KITTI, named so that both runs say it (before a
  # configuration file changed only its own keys, it replaced the automatic preset).
  "$bin" run --dataset "kitti:$data/kitti_seq1" --poses gt --preset outdoor --device cuda --iterations "$it" --out "$work/$name" \
    "$@" >"$work/$name.log" 2>&1 || { echo "kitti_steps: $name failed:"; tail -n 5 "$work/$name.log"; }
}
for v in cache no_cache; do
  extra=()
  [[ $v == no_cache ]] && extra=(--config "$work/no_cache.yaml")
  run "${v}_30" 30 "${extra[@]}"
  run "${v}_300" 300 "${extra[@]}"
done
python3 - "$work" "${OUT:-}" <<'PY'
import json, os, sys
work, out = sys.argv[1], sys.argv[2]
rows = {}
for v in ("cache", "no_cache"):
    r30, r300 = (json.load(open(os.path.join(work, f"{v}_{n}", "report.json"))) for n in (30, 300))
    dt = r300["time"]["mapping_s"] - r30["time"]["mapping_s"]
    di = r300["iterations"] - r30["iterations"]
    rows[v] = {"ms_per_step": 1000 * dt / di, "steps_per_s": di / dt,
               "psnr_30": r30["held_out"]["mean_psnr"], "psnr_300": r300["held_out"]["mean_psnr"],
               "mapping_s_30": r30["time"]["mapping_s"], "mapping_s_300": r300["time"]["mapping_s"],
               "step_ms_300": r300.get("step_ms"), "step_ms_30": r30.get("step_ms"),
               "total_300": r300["gaussians"]["total"]}
    print(v, json.dumps(rows[v]))
if out:
    json.dump(rows, open(os.path.join(out, "kitti_steps.json"), "w"), indent=1)
PY
