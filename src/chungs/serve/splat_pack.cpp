#include "chungs/serve/splat_pack.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>

#include "chungs/common/error.hpp"
#include "chungs/render/sh.hpp"
#include "chungs/store/half_float.hpp"

namespace chungs::serve {

uint32_t encode_rotation(float w, float x, float y, float z) {
  double n = std::sqrt(double(w) * w + double(x) * x + double(y) * y + double(z) * z);
  if (!(n > 0) || !std::isfinite(n)) return 0;  // a degenerate rotation draws as the identity
  // q and -q are one rotation: keep w >= 0 so the angle lies in [0, pi].
  const double s = (w < 0 ? -1.0 : 1.0) / n;
  const double qw = w * s, qx = x * s, qy = y * s, qz = z * s;
  const double theta = 2 * std::acos(std::clamp(qw, -1.0, 1.0));
  const double axis_norm = std::sqrt(qx * qx + qy * qy + qz * qz);
  double ax = 1, ay = 0, az = 0;
  if (axis_norm >= 1e-6) ax = qx / axis_norm, ay = qy / axis_norm, az = qz / axis_norm;
  // Octahedral map of the unit axis onto [-1, 1]^2, the lower half folded over the diagonals.
  const double sum = std::abs(ax) + std::abs(ay) + std::abs(az);
  double px = ax / sum, py = ay / sum;
  if (az < 0) {
    const double ox = px;
    px = (1 - std::abs(py)) * (px >= 0 ? 1 : -1);
    py = (1 - std::abs(ox)) * (py >= 0 ? 1 : -1);
  }
  const auto u = uint32_t(std::lround(std::clamp(px * 0.5 + 0.5, 0.0, 1.0) * 1023));
  const auto v = uint32_t(std::lround(std::clamp(py * 0.5 + 0.5, 0.0, 1.0) * 1023));
  const auto a = uint32_t(std::lround(std::clamp(theta / std::numbers::pi, 0.0, 1.0) * 4095));
  return a << 20 | v << 10 | u;
}

void decode_rotation(uint32_t word, float q[4]) {
  double fx = (word & 1023u) / 1023.0 * 2 - 1, fy = ((word >> 10) & 1023u) / 1023.0 * 2 - 1;
  const double fz = 1 - std::abs(fx) - std::abs(fy);
  const double t = std::max(-fz, 0.0);
  fx += fx >= 0 ? -t : t;
  fy += fy >= 0 ? -t : t;
  const double len = std::sqrt(fx * fx + fy * fy + fz * fz);
  const double half = (word >> 20) / 4095.0 * std::numbers::pi * 0.5;
  const double s = len < 1e-6 ? 0 : std::sin(half) / len;
  q[0] = float(std::cos(half));
  q[1] = float(fx * s);
  q[2] = float(fy * s);
  q[3] = float(fz * s);
}

uint32_t encode_sh_rgb(float r, float g, float b) {
  const float m = std::max({std::abs(r), std::abs(g), std::abs(b)});
  // Non-finite values are the map's bug, not the viewer's: they draw as zero.
  if (!std::isfinite(m) || m == 0) return 0;
  // The smallest power of two above the largest magnitude, so that one reaches 255 at most.
  const int e = std::clamp(int(std::floor(std::log2(m))) + 1 + 15, 0, 31);
  const double step = std::ldexp(1.0, e - 15) / 255;
  auto mag = [&](float c) { return uint32_t(std::lround(std::clamp(std::abs(c) / step, 0.0, 255.0))); };
  const uint32_t signs = (r < 0 ? 1u : 0u) | (g < 0 ? 2u : 0u) | (b < 0 ? 4u : 0u);
  return mag(r) | mag(g) << 8 | mag(b) << 16 | (uint32_t(e) << 3 | signs) << 24;
}

void decode_sh_rgb(uint32_t word, float rgb[3]) {
  const double step = std::ldexp(1.0, int((word >> 27) & 31u) - 15) / 255;
  for (int c = 0; c < 3; ++c) {
    const double v = ((word >> (8 * c)) & 255u) * step;
    rgb[c] = float(word & (1u << (24 + c)) ? -v : v);
  }
}

std::string pack_splats(const GaussianParams& p, int sh_degree, const double origin[3], ChunkId id,
                        uint64_t generation) {
  if (sh_degree < 0 || sh_degree > kMaxShDegree) fail("SH degree ", sh_degree, " is outside 0..3");
  const size_t n = p.size();
  std::string out(splat_pack_bytes(n, sh_degree), '\0');
  char* h = out.data();
  std::memcpy(h, "DCSPLAT1", 8);
  const uint32_t head[4] = {kSplatPackVersion, uint32_t(n), uint32_t(sh_degree), kSplatPackHeaderBytes};
  std::memcpy(h + 8, head, sizeof head);
  std::memcpy(h + 24, origin, 3 * sizeof(double));
  std::memcpy(h + 48, &id, 8);
  std::memcpy(h + 56, &generation, 8);

  auto array = [&](int k) { return reinterpret_cast<uint32_t*>(h + kSplatPackHeaderBytes + size_t(k) * 16 * n); };
  uint32_t *a = array(0), *b = array(1);
  auto half = [](double v) { return uint32_t(float_to_half(float(v))); };
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      const float rel = float(double(p.mean[3 * i + k]) - origin[k]);
      std::memcpy(&a[4 * i + k], &rel, 4);
    }
    a[4 * i + 3] = half(1 / (1 + std::exp(-double(p.opacity[i]))));
    const float* sh = &p.sh[size_t(kShFloats) * i];
    const double c0 = sh::kC0;
    const float* ls = &p.log_scale[3 * i];
    b[4 * i + 0] = half(0.5 + c0 * sh[0]) | half(0.5 + c0 * sh[1]) << 16;
    b[4 * i + 1] = half(0.5 + c0 * sh[2]) | half(ls[0]) << 16;
    b[4 * i + 2] = half(ls[1]) | half(ls[2]) << 16;
    const float* q = &p.rotation[4 * i];
    b[4 * i + 3] = encode_rotation(q[0], q[1], q[2], q[3]);
  }
  if (sh_degree == 0) return out;
  auto coeff = [&](size_t i, int k) {
    const float* c = &p.sh[size_t(kShFloats) * i + 3 * size_t(k)];
    return encode_sh_rgb(c[0], c[1], c[2]);
  };
  uint32_t* s1 = array(2);
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) s1[4 * i + k] = coeff(i, 1 + k);
    s1[4 * i + 3] = sh_degree >= 2 ? coeff(i, 4) : 0;
  }
  if (sh_degree == 1) return out;
  uint32_t* s2 = array(3);
  for (size_t i = 0; i < n; ++i)
    for (int k = 0; k < 4; ++k) s2[4 * i + k] = coeff(i, 5 + k);
  if (sh_degree == 2) return out;
  uint32_t *s3a = array(4), *s3b = array(5);
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 4; ++k) s3a[4 * i + k] = coeff(i, 9 + k);
    for (int k = 0; k < 3; ++k) s3b[4 * i + k] = coeff(i, 13 + k);
  }
  return out;
}

}  // namespace chungs::serve
