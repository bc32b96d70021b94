#!/usr/bin/env bash
# Builds the CUDA configuration (sm_90, Release, tests and benchmarks) and gathers the GPU test and
# benchmark executables and the CLI, with their shared libraries, into one relocatable folder for a
# GPU machine that has only CUDA and a few libraries (no OpenCV, no Ceres) and cannot install any.
# The C runtime (glibc, libstdc++, libgcc_s, libm, the loader) and the CUDA driver come from the
# target machine; everything else the executables load is copied.
#
# Usage: scripts/gpu_bundle.sh [BUNDLE_DIR]      (default: .gpu/bundle; .gpu/ is git-ignored)
# Env:   BUILD_DIR (default build-gpu), JOBS (default 2), CUDA_ARCHS (default 90), WITH_ONNXRUNTIME=1 (add
#        ONNX Runtime's library for --mono-depth-model, 46 MB),
#        TARGETS (default: test_render test_optim test_residency bench_cuda_rasterizer diskchungs)
# Then on the GPU machine: scripts/gpu_run.sh OUTDIR   (with .gpu carried along)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bundle=${1:-$root/.gpu/bundle}
build=${BUILD_DIR:-$root/build-gpu}
jobs=${JOBS:-2}
archs=${CUDA_ARCHS:-90}
targets=${TARGETS:-"test_render test_optim test_residency bench_cuda_rasterizer diskchungs"}

mkdir -p "$build"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCHUNGS_CUDA=ON \
  -DCMAKE_CUDA_ARCHITECTURES="$archs" -DCHUNGS_TESTS=ON -DCHUNGS_BENCH=ON >"$build/configure.log" 2>&1 ||
  { cat "$build/configure.log"; exit 1; }
# shellcheck disable=SC2086
ninja -C "$build" -j "$jobs" $targets

rm -rf "$bundle"
mkdir -p "$bundle/bin" "$bundle/lib"
exes=()
for t in $targets; do
  exe=$(find "$build" -maxdepth 3 -type f -name "$t" -perm -u+x | head -n 1)
  [[ -n "$exe" ]] || { echo "gpu_bundle: built target $t not found under $build" >&2; exit 1; }
  cp "$exe" "$bundle/bin/"
  exes+=("$exe")
done

# Shared-library closure, minus what every Linux system (and the GPU driver) provides.
skip='^(linux-vdso|ld-linux|libc\.so|libm\.so|libstdc\+\+|libgcc_s|libpthread|libdl\.so|librt\.so|libcuda\.so|libnvidia)'
for exe in "${exes[@]}"; do
  ldd "$exe" | awk '/=> \// {print $1, $3}' | while read -r name path; do
    [[ "$name" =~ $skip ]] && continue
    [[ -e "$bundle/lib/$name" ]] || cp -L "$path" "$bundle/lib/$name"
  done
done
# ONNX Runtime for --mono-depth-model: opened at run time (not in any ldd closure) as libonnxruntime.so.1,
# which the bundle's LD_LIBRARY_PATH finds here; the npm copy the build installs (cmake/onnxruntime.cmake).
# Only with WITH_ONNXRUNTIME=1: the library is 46 MB, and a bundle with it and KITTI's excerpt no longer fits
# what a lent GPU machine is given (64 MiB).
if [[ ${WITH_ONNXRUNTIME:-0} == 1 ]] && ninja -C "$build" onnxruntime >/dev/null 2>&1; then
  ort="$build/onnxruntime/node_modules/onnxruntime-node/bin/napi-v6/linux/x64/libonnxruntime.so.1"
  [[ -e "$ort" ]] && cp -L "$ort" "$bundle/lib/libonnxruntime.so.1"
fi
# Missing libraries make ldd print "not found": fail here, not on the GPU machine.
if ldd "${exes[@]}" | grep -q "not found"; then
  ldd "${exes[@]}" | grep "not found" >&2
  exit 1
fi

{
  echo "commit $(git -C "$root" rev-parse HEAD 2>/dev/null || echo unknown)"
  echo "dirty $(git -C "$root" status --porcelain -- src tests bench apps cmake 2>/dev/null | wc -l) files"
  echo "built $(date -u +%FT%TZ) on $(uname -n), CUDA archs $archs"
  echo "targets $targets"
} >"$bundle/MANIFEST"
du -sh "$bundle" "$bundle/lib"
echo "bundle ready: $bundle"
