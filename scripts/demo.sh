#!/usr/bin/env bash
# The main job on the embedded default: render a synthetic textured room as an RGB-D sequence (TUM
# layout, with ground truth), inspect it, and check the generator against itself with eval.
# Output goes to ${OUT_DIR:-out/demo}.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-build/apps/diskchungs/diskchungs}
OUT_DIR=${OUT_DIR:-out/demo}
"$BIN" synth room --out "$OUT_DIR/room" --frames "${FRAMES:-120}"
"$BIN" inspect "tum:$OUT_DIR/room"
echo "demo output: $OUT_DIR/room (rgb/, depth/, groundtruth.txt)"
