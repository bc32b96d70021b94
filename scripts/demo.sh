#!/usr/bin/env bash
# The main job (a thin wrapper over `diskchungs demo`): render a synthetic textured room as an RGB-D
# sequence with ground truth, map it on its ground-truth poses into a chunked Gaussian map under a
# memory budget, export it as a 3DGS PLY and print held-out PSNR/SSIM, speed, memory and chunk I/O.
# About 30 s on 2 cores. Output goes to ${OUT_DIR:-out/demo}: room/ (the sequence), map/ (report.json,
# timeline.csv, memory.png, renders/), map.ply. Extra arguments go to `diskchungs demo`.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-build/apps/diskchungs/diskchungs}
exec "$BIN" demo --out "${OUT_DIR:-out/demo}" --frames "${FRAMES:-120}" "$@"
