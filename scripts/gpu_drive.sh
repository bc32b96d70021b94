#!/usr/bin/env bash
# The long-drive benchmark on a lent GPU machine (bench/README.md, "A 10 km drive"): a drive longer
# than one command may last runs detached, and later commands wait for it and collect its results.
#   scripts/gpu_drive.sh start NAME SPEED [LENGTH_M]   start `diskchungs run` on the synthetic street
#                                                      (default 10000 m) with frames arriving at SPEED
#                                                      times 36 km/h; returns at once
#   scripts/gpu_drive.sh wait NAME SECONDS             wait until it ends or SECONDS pass, print progress;
#                                                      once it has ended, copy report.json, timeline.csv,
#                                                      memory.png and the log to $OUT as NAME_*
# Env: BUNDLE (default .gpu/k10, from `TARGETS=diskchungs scripts/gpu_bundle.sh .gpu/k10`),
#      WORK (default /tmp/drive: map folders; the machine's local disk), EXTRA (more `run` arguments),
#      EXTRA_YAML (more lines of the run's configuration file, e.g. "selector: {revisit_share: 1}").
set -uo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bundle=${BUNDLE:-$root/.gpu/k10}
work=${WORK:-/tmp/drive}
verb=${1:?usage: gpu_drive.sh start NAME SPEED [LENGTH_M] | wait NAME SECONDS}
name=${2:?name}
dir=$work/$name

case $verb in
start)
  speed=${3:?speed}
  length=${4:-10000}
  [[ -x $bundle/bin/diskchungs ]] || { echo "gpu_drive: no bundle at $bundle" >&2; exit 1; }
  rm -rf "$dir" && mkdir -p "$dir"
  cat >"$dir/c.yaml" <<YAML
mapper: {eval_keyframe_stride: 20, pacing: anytime, speed: $speed}
${EXTRA_YAML:-}
YAML
  export LD_LIBRARY_PATH=$bundle/lib
  "$bundle/bin/diskchungs" info >"$dir/info.txt" 2>&1
  # setsid: the run outlives this command (the machine ends it only when it is given back).
  # shellcheck disable=SC2086
  setsid bash -c "'$bundle/bin/diskchungs' run --dataset synth-street:length=$length,width=620,height=188 \
    --poses gt --out '$dir/map' --device cuda --config '$dir/c.yaml' ${EXTRA:-} >'$dir/log' 2>&1; \
    echo \$? >'$dir/exit'" </dev/null >/dev/null 2>&1 &
  sleep 5
  cat "$dir/info.txt"
  tail -c 600 "$dir/log"
  ;;
wait)
  seconds=${3:?seconds}
  [[ -d $dir ]] || { echo "gpu_drive: no run named $name in $work" >&2; exit 1; }
  end=$((SECONDS + seconds))
  while [[ ! -f $dir/exit && $SECONDS -lt $end ]]; do sleep 5; done
  tail -c 1500 "$dir/log" | tr '\r' '\n' | tail -n 8
  if [[ -f $dir/map/timeline.csv ]]; then tail -n 1 "$dir/map/timeline.csv"; fi
  if [[ -f $dir/exit ]]; then
    echo "exit status $(cat "$dir/exit")"
    out=${OUT:-$dir/out}
    mkdir -p "$out"
    cp "$dir/log" "$out/${name}_log.txt"
    for f in report.json timeline.csv memory.png; do
      [[ -f $dir/map/$f ]] && cp "$dir/map/$f" "$out/${name}_$f"
    done
    du -sh "$dir/map"
  else
    echo "still running"
  fi
  ;;
*) echo "gpu_drive: unknown verb $verb" >&2; exit 2 ;;
esac
