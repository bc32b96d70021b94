#!/usr/bin/env bash
# The main job (a thin wrapper over `diskchungs demo`): a synthetic stereo street whose route comes
# back to its start, mapped on its ground-truth poses into a chunked Gaussian map whose budget is a
# fraction of the map, so chunks go to disk and are loaded back; exported as a 3DGS PLY, with held-out
# PSNR/SSIM, speed, memory and chunk I/O printed. About a minute on 2 cores. Output goes to
# ${OUT_DIR:-out/demo}: map/ (report.json, timeline.csv, memory.png, renders/) and map.ply.
# Extra arguments go to `diskchungs demo` (e.g. `--scene room` for the RGB-D room).
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-build/apps/diskchungs/diskchungs}
exec "$BIN" demo --out "${OUT_DIR:-out/demo}" "$@"
