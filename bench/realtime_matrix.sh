#!/usr/bin/env bash
# The real-time benchmark of bench/README.md ("Real-time mapping with the defaults"), on a lent GPU
# machine. Every run uses the defaults (no configuration file); only the flags the cells name.
#   bench/realtime_matrix.sh start      start all runs one group after another, detached from the
#                                       command-time limit; returns at once
#   bench/realtime_matrix.sh wait SECS  wait until all runs ended or SECS passed; print progress
#   bench/realtime_matrix.sh collect    summary.json (one row per run) and results.tgz (reports,
#                                       timelines, memory plots, logs) into $OUT
# Runs, in order: the real KITTI excerpt at its real rate (10 Hz, full resolution; given and tracked
# poses); the 2 km street at 620x188 x {anytime 72 km/h, anytime 36 km/h, fixed 30 steps per
# keyframe} x {default budget, 300 000, 100 000} (the three budgets of a pacing side by side on the one
# GPU, so they share it alike); the 10 km drive at 72 km/h runs alone, after KITTI.
# On 4 GPUs or more the runs are spread over them instead, each alone on its GPU (see lanes below).
# Env: BUNDLE (default .gpu/rt, from `TARGETS=diskchungs scripts/gpu_bundle.sh .gpu/rt`), DATA (a
# folder holding kitti_seq1), WORK (default /tmp/rt), SEED (street, default 3), SKIP_DRIVE=1,
# SKIP_KITTI=1, EXTRA_ARGS (words added to every run, e.g. "--config FILE"), PACINGS (default "a72 a36 fixed": the groups of the matrix to run; "none" runs none;
# "speeds" runs 20, 36 and 72 km/h at the default budget side by side, issue 20's ordering),
# BUDGETS (default "default b300k b100k": the cells of each group; e.g. "b300k b100k" for a second
# instance with other EXTRA_ARGS and its own WORK, started beside the first on the same GPU),
# LPIPS_WEIGHTS (a DCLPIPS1 file, scripts/lpips_convert.py: every run also scores LPIPS; without it
# the summary's lpips_held_out is null and lpips_unavailable says why).
set -uo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bundle=${BUNDLE:-$root/.gpu/rt}
data=${DATA:-$root/.gpu/data}
work=${WORK:-/tmp/rt}
seed=${SEED:-3}
export LD_LIBRARY_PATH=$bundle/lib
bin=$bundle/bin/diskchungs

cell() {  # cell NAME ARGS...: one mapping run in $work/NAME
  local name=$1
  shift
  mkdir -p "$work/$name"
  echo "$*" >"$work/$name/args"
  local poses=(--poses gt) lpips=()
  [[ " $* " == *" --poses "* ]] && poses=()
  [[ -n ${LPIPS_WEIGHTS:-} ]] && lpips=(--lpips-weights "$LPIPS_WEIGHTS")
  # shellcheck disable=SC2086 # EXTRA_ARGS: words added to every run (e.g. --config FILE for an A/B of a setting)
  "$bin" run "${poses[@]}" "${lpips[@]}" --out "$work/$name/map" --device cuda "$@" ${EXTRA_ARGS:-} >"$work/$name/log" 2>&1
  echo $? >"$work/$name/exit"
}

street() { echo "synth-street:length=$1,width=620,height=188,seed=$seed"; }

# On a host of 4 GPUs or more (unless SIDE_BY_SIDE=1) every run has a GPU to itself: four lanes run at
# once, each a list of runs one after another on its GPU (lane 0: KITTI, then the drive). Steps taken
# under anytime pacing depend on the GPU's share, so runs alone compare with runs alone only.
on() {  # on GPU NAME ARGS...: a cell on GPU number GPU alone
  local gpu=$1
  shift
  CUDA_VISIBLE_DEVICES=$gpu cell "$@"
}

lanes() {
  local s2k a36=(--pacing anytime) a72=(--pacing anytime --speed 2)
  s2k=$(street 2000)
  {
    if [[ ${SKIP_KITTI:-0} != 1 ]]; then
      on 0 kitti_anytime --dataset "kitti:$data/kitti_seq1" --pacing anytime
      on 0 kitti_anytime_track --dataset "kitti:$data/kitti_seq1" --pacing anytime --poses track
    fi
    [[ ${SKIP_DRIVE:-0} == 1 ]] || on 0 drive10k_a72 --dataset "$(street 10000)" "${a72[@]}"
  } &
  { on 1 a36_default --dataset "$s2k" "${a36[@]}"; on 1 a36_b300k --dataset "$s2k" "${a36[@]}" --budget 300000; } &
  {
    on 2 a36_b100k --dataset "$s2k" "${a36[@]}" --budget 100000
    on 2 a72_default --dataset "$s2k" "${a72[@]}"
    on 2 a72_b300k --dataset "$s2k" "${a72[@]}" --budget 300000
  } &
  {
    on 3 fixed_default --dataset "$s2k"
    on 3 fixed_b300k --dataset "$s2k" --budget 300000
    on 3 fixed_b100k --dataset "$s2k" --budget 100000
    on 3 a72_b100k --dataset "$s2k" "${a72[@]}" --budget 100000
  } &
  wait
}

all() {
  "$bin" info >"$work/info.txt" 2>&1
  nvidia-smi >"$work/nvidia-smi.txt" 2>&1
  if [[ ${SIDE_BY_SIDE:-0} != 1 && ${PACINGS:-} == "" ]] && (($(nvidia-smi -L | grep -c '^GPU') >= 4)); then
    lanes
    touch "$work/done"
    return
  fi
  if [[ ${SKIP_KITTI:-0} != 1 ]]; then
    cell kitti_anytime --dataset "kitti:$data/kitti_seq1" --pacing anytime
    cell kitti_anytime_track --dataset "kitti:$data/kitti_seq1" --pacing anytime --poses track
  fi
  # Alone on the GPU (its VRAM figures are device-wide), before the groups.
  [[ ${SKIP_DRIVE:-0} == 1 ]] || cell drive10k_a72 --dataset "$(street 10000)" --pacing anytime --speed 2
  # The fast intakes first: the slowest group (fixed pacing) last.
  for pacing in ${PACINGS:-a72 a36 fixed}; do
    if [[ $pacing == speeds ]]; then
      # Issue 20's ordering: 20, 36 and 72 km/h at the default budget, side by side on the one GPU.
      cell speed20_default --dataset "$(street 2000)" --pacing anytime --speed 0.5556 &
      cell speed36_default --dataset "$(street 2000)" --pacing anytime &
      cell speed72_default --dataset "$(street 2000)" --pacing anytime --speed 2 &
      wait
      continue
    fi
    case $pacing in
    none) continue ;;
    fixed) args=() ;;
    a36) args=(--pacing anytime) ;;
    a72) args=(--pacing anytime --speed 2) ;;
    esac
    for b in ${BUDGETS:-default b300k b100k}; do
      case $b in
      default) cell "${pacing}_default" --dataset "$(street 2000)" "${args[@]}" & ;;
      b300k) cell "${pacing}_b300k" --dataset "$(street 2000)" "${args[@]}" --budget 300000 & ;;
      b100k) cell "${pacing}_b100k" --dataset "$(street 2000)" "${args[@]}" --budget 100000 & ;;
      *) echo "realtime_matrix: unknown budget $b (known: default b300k b100k)" >&2 ;;
      esac
    done
    wait
  done
  touch "$work/done"
}

case ${1:?usage: realtime_matrix.sh start | wait SECONDS | collect | all} in
start)
  [[ -x $bin ]] || { echo "realtime_matrix: no bundle at $bundle" >&2; exit 1; }
  rm -rf "$work" && mkdir -p "$work"
  setsid bash "${BASH_SOURCE[0]}" all </dev/null >"$work/runner.log" 2>&1 &
  sleep 3
  echo "started in $work"
  ;;
all) all ;;
wait)
  end=$((SECONDS + ${2:?seconds}))
  while [[ ! -f $work/done && $SECONDS -lt $end ]]; do sleep 5; done
  for d in "$work"/*/; do
    n=$(basename "$d")
    if [[ -f $d/exit ]]; then
      echo "$n: exit $(cat "$d/exit")"
      grep -aE "^(held-out|pacing|host RSS|VRAM|tracking)" "$d/log" | cut -c1-260
    else
      echo "$n: running: $(tail -c 300 "$d/log" | tr '\r' '\n' | tail -n 1)"; fi
  done
  [[ -f $work/done ]] && echo "all done"
  ;;
collect)
  out=${OUT:?OUT}
  python3 - "$work" "$out/summary.json" <<'PY'
import json, os, sys
work, dst = sys.argv[1], sys.argv[2]
rows = {}
for n in sorted(os.listdir(work)):
    rp = os.path.join(work, n, "map", "report.json")
    if not os.path.isfile(rp):
        continue
    r = json.load(open(rp))
    p, t, g = r.get("pacing", {}), r["time"], r["gaussians"]
    row = {"args": open(os.path.join(work, n, "args")).read().strip(),
           "exit": open(os.path.join(work, n, "exit")).read().strip() if os.path.exists(os.path.join(work, n, "exit")) else None,
           "psnr_held_out": r.get("held_out", {}).get("mean_psnr"),
           "ssim_held_out": r.get("held_out", {}).get("mean_ssim"),
           "lpips_held_out": r.get("held_out", {}).get("mean_lpips"),
           "lpips_unavailable": r.get("held_out", {}).get("lpips_unavailable"),
           "psnr_keyframes": r.get("keyframes_eval", {}).get("mean_psnr"),
           "io_wait_share": t.get("io_wait_share"), "fps": t.get("processing_fps"),
           "mapping_s": t.get("mapping_s"), "intake_kmh": t.get("intake_kmh"),
           "keyframes": r.get("keyframes"), "iterations": r.get("iterations"),
           "total": g.get("total"), "peak_resident": g.get("peak_resident"), "budget": g.get("budget"),
           "chunks": g.get("chunks"), "loads": r["chunk_io"]["loads"], "saves": r["chunk_io"]["saves"],
           "disk_gb": r["disk"]["bytes"] / 1e9}
    row.update({"pacing_" + k: v for k, v in p.items()})
    if "tracking" in r and "ate" in r["tracking"]:
        row["ate_rmse"] = r["tracking"]["ate"]["rmse"]
    ab = r.get("memory", {}).get("after_budget")
    if ab:
        for k in ("rss", "vram"):
            if k in ab:
                row[k + "_flat"] = {x: ab[k][x] for x in ("plateau_mb", "max_above", "max_below", "within_share", "settled_after_s")}
    rows[n] = row
json.dump(rows, open(dst, "w"), indent=1)
for n, row in rows.items():
    print(n, {k: row[k] for k in ("psnr_held_out", "io_wait_share", "fps", "total", "pacing_steps_per_keyframe_mean", "pacing_dropped_keyframes")})
PY
  (cd "$work" && tar czf "$out/results.tgz" --exclude='*/map/chunks' --exclude='*/map/keyframes' \
    --exclude='*/map/renders' --exclude='*/map/checkpoint-*' ./*/log ./*/args ./*/exit ./*/map/report.json \
    ./*/map/timeline.csv ./*/map/memory.png ./*.txt 2>/dev/null)
  # A few held-out renders of each default-budget run and the drive, to look at.
  (cd "$work" && find . \( -path './*_default/map/renders/*' -o -path './drive*/map/renders/*' \) -name '*.png' | sort | awk 'NR % 8 == 1' | head -n 40 |
    tar czf "$out/renders.tgz" -T - 2>/dev/null)
  ls -la "$out"
  ;;
*) echo "realtime_matrix: unknown verb $1" >&2; exit 2 ;;
esac
