#!/usr/bin/env bash
# The main job: render a synthetic textured room as an RGB-D sequence (TUM layout, ground truth),
# map it on its ground-truth poses into a chunked Gaussian map under a memory budget, and report
# held-out PSNR/SSIM, speed, memory and chunk I/O. A few minutes on 2 cores.
# Output goes to ${OUT_DIR:-out/demo}: room/ (the sequence), map/ (the map folder with report.json,
# timeline.csv, memory.png, renders/), map.ply (the map for any 3DGS viewer).
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-build/apps/diskchungs/diskchungs}
OUT_DIR=${OUT_DIR:-out/demo}
FRAMES=${FRAMES:-120}
"$BIN" synth room --out "$OUT_DIR/room" --frames "$FRAMES"
rm -rf "$OUT_DIR/map"
"$BIN" run --dataset "tum:$OUT_DIR/room" --poses gt --out "$OUT_DIR/map" \
  --resolution "${RESOLUTION:-0.25}" --iterations "${ITERATIONS:-10}" --final-iterations 100 \
  --budget "${BUDGET:-200000}" --chunk-size "${CHUNK_SIZE:-2}"
"$BIN" export --map "$OUT_DIR/map" --out "$OUT_DIR/map.ply"
echo "demo output: $OUT_DIR/map (report.json, timeline.csv, memory.png, renders/), $OUT_DIR/map.ply"
