// A chunk's Gaussians packed for the browser viewer (GET /api/chunk/<id>): the arrays Spark's
// ExtSplats keeps on the GPU, written here so the page hands them to Spark as typed-array views of
// the response, with no per-Gaussian work in JavaScript.
//
// Layout (version 1), little-endian, every array a run of uint32 words starting on a 4-byte boundary:
//   offset  0  char[8]   magic "DCSPLAT1"
//           8  uint32    version (1)
//          12  uint32    count: Gaussians in the chunk (n)
//          16  uint32    sh_degree served (0..3): how many SH arrays follow
//          20  uint32    header bytes (64): where the arrays begin
//          24  float64   origin x, y, z: world position (metres) the centres are relative to (the
//                        chunk's centre), so float32 keeps millimetres however far the map reaches
//          48  uint64    chunk id
//          56  uint64    generation of the chunk file read (the manifest's)
//          64  uint32[4n] ext A, per Gaussian: centre x, y, z as float32 bits (minus origin);
//                         opacity (after the sigmoid) as binary16 in the low half of word 3
//              uint32[4n] ext B: binary16 pairs (r, g) (b, ln sx) (ln sy, ln sz), then the rotation as
//                         octahedral axis 10+10 bits and angle 12 bits (axis u in bits 0-9, v in
//                         10-19, angle in 20-31, for the quaternion with w >= 0); rgb is the
//                         degree-0 colour 0.5 + C0 * dc, not clamped
//   sh >= 1    uint32[4n] sh1: words 0-2 the degree-1 coefficients 1..3, word 3 the degree-2
//                         coefficient 4 (0 when sh < 2)
//   sh >= 2    uint32[4n] sh2: degree-2 coefficients 5..8
//   sh == 3    uint32[4n] sh3a: degree-3 coefficients 9..12
//              uint32[4n] sh3b: coefficients 13..15, word 3 zero
// An SH word holds one coefficient's r, g, b as 8-bit magnitudes with a shared power-of-two scale:
// bits 0-7 r, 8-15 g, 16-23 b, 24-26 the signs of r, g, b, 27-31 the exponent e + 15, value =
// magnitude * 2^e / 255. Coefficients are in the basis and order of 3DGS (render/sh.hpp), which
// Spark evaluates the same way.
#pragma once
#include <cstdint>
#include <string>

#include "chungs/gaussians/gaussian_block.hpp"
#include "chungs/store/chunk_id.hpp"

namespace chungs::serve {

constexpr uint32_t kSplatPackVersion = 1;
constexpr uint32_t kSplatPackHeaderBytes = 64;

// Bytes of a packed chunk of n Gaussians at an SH degree.
inline size_t splat_pack_bytes(size_t n, int sh_degree) {
  const int arrays = 2 + (sh_degree >= 1) + (sh_degree >= 2) + 2 * (sh_degree >= 3);
  return kSplatPackHeaderBytes + size_t(arrays) * 16 * n;
}

// Packs `params` at `sh_degree` (at most the block's own). Throws Error on a degree out of range.
std::string pack_splats(const GaussianParams& params, int sh_degree, const double origin[3], ChunkId id,
                        uint64_t generation);

// The encodings, exposed for tests (and their decoders, which mirror Spark's).
uint32_t encode_rotation(float w, float x, float y, float z);
void decode_rotation(uint32_t word, float q_wxyz[4]);
uint32_t encode_sh_rgb(float r, float g, float b);
void decode_sh_rgb(uint32_t word, float rgb[3]);

}  // namespace chungs::serve
