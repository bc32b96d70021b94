#include "chungs/store/chunk_codec.hpp"

#include <cmath>
#include <cstring>

#include "chungs/store/half_float.hpp"

namespace chungs {

namespace {

constexpr int kShRest = kShFloats - 3;

enum class Kind { Raw, ShDc, ShRest, Half, HalfSqrt };

struct Field {
  Kind kind;
  float* f;         // the block's float array (Raw floats, all non-Raw kinds)
  void* raw;        // Raw: the array's memory
  size_t elements;  // values stored (for ShDc/ShRest: per kind)
};

// The file order of the version 1 layout, with SH and moments switched to their encodings.
std::vector<Field> fields_of(GaussianBlock& b, uint32_t flags) {
  const size_t n = b.size();
  std::vector<Field> out;
  auto raw = [&](auto& v) { out.push_back({Kind::Raw, nullptr, v.data(), v.size()}); };
  for (GaussianParams* p : {&b.params, &b.adam_m, &b.adam_v}) {
    const bool moment = p != &b.params;
    const Kind half = p == &b.adam_v ? Kind::HalfSqrt : Kind::Half;
    for (std::vector<float>* v : {&p->mean, &p->log_scale, &p->rotation, &p->opacity, &p->sh}) {
      if (moment && (flags & kChunkFlagHalfMoments)) {
        out.push_back({half, v->data(), nullptr, v->size()});
      } else if (!moment && v == &p->sh && (flags & kChunkFlagHalfShRest)) {
        out.push_back({Kind::ShDc, v->data(), nullptr, 3 * n});
        out.push_back({Kind::ShRest, v->data(), nullptr, size_t(kShRest) * n});
      } else {
        raw(*v);
      }
    }
  }
  for (std::vector<uint32_t>* v : {&b.adam_steps, &b.created_by_keyframe, &b.created_at_step}) raw(*v);
  raw(b.lr_position_factor);
  return out;
}

size_t stored_bytes(const Field& f) {
  return f.kind == Kind::Raw || f.kind == Kind::ShDc ? 4 * f.elements : 4 + 2 * f.elements;
}

// Reads value i of a non-Raw field from the block (SH split by coefficient).
float value(const Field& f, size_t i) {
  if (f.kind == Kind::ShDc) return f.f[(i / 3) * kShFloats + i % 3];
  if (f.kind == Kind::ShRest) return f.f[(i / kShRest) * kShFloats + 3 + i % kShRest];
  return f.f[i];
}
float& slot(const Field& f, size_t i) {
  if (f.kind == Kind::ShDc) return f.f[(i / 3) * kShFloats + i % 3];
  if (f.kind == Kind::ShRest) return f.f[(i / kShRest) * kShFloats + 3 + i % kShRest];
  return f.f[i];
}

float signed_sqrt(float v) { return std::copysign(std::sqrt(std::fabs(v)), v); }

void encode(const Field& f, uint8_t* out) {
  if (f.kind == Kind::ShDc) {
    for (size_t i = 0; i < f.elements; ++i) {
      const float v = value(f, i);
      std::memcpy(out + 4 * i, &v, 4);
    }
    return;
  }
  const bool root = f.kind == Kind::HalfSqrt;
  float largest = 0;
  for (size_t i = 0; i < f.elements; ++i) {
    const float a = std::fabs(root ? signed_sqrt(value(f, i)) : value(f, i));
    if (std::isfinite(a)) largest = std::max(largest, a);
  }
  int e = 0;
  std::frexp(largest, &e);  // largest < 2^e
  const float scale = largest > 0 ? std::ldexp(1.0f, e - 15) : 1.0f;
  std::memcpy(out, &scale, 4);
  const float inv = 1.0f / scale;  // exact: a power of two
  for (size_t i = 0; i < f.elements; ++i) {
    const float x = root ? signed_sqrt(value(f, i)) : value(f, i);
    uint16_t h = float_to_half(x * inv);
    if (root && x != 0 && (h & 0x7fff) == 0) h = uint16_t((h & 0x8000) | 1);
    std::memcpy(out + 4 + 2 * i, &h, 2);
  }
}

void decode(const Field& f, const uint8_t* in) {
  if (f.kind == Kind::ShDc) {
    for (size_t i = 0; i < f.elements; ++i) std::memcpy(&slot(f, i), in + 4 * i, 4);
    return;
  }
  float scale;
  std::memcpy(&scale, in, 4);
  for (size_t i = 0; i < f.elements; ++i) {
    uint16_t h;
    std::memcpy(&h, in + 4 + 2 * i, 2);
    const float x = half_to_float(h) * scale;
    slot(f, i) = f.kind == Kind::HalfSqrt ? x * std::fabs(x) : x;
  }
}

}  // namespace

uint64_t chunk_payload_bytes(uint64_t count, uint32_t flags) {
  // The arithmetic of fields_of without a block: 4-byte arrays, or a scale plus 2-byte values.
  const uint64_t raw_params = 3 + 3 + 4 + 1, n = count;
  uint64_t bytes = 4 * n * (3 + 1);  // bookkeeping words
  const bool half_sh = flags & kChunkFlagHalfShRest, half_m = flags & kChunkFlagHalfMoments;
  bytes += half_sh ? 4 * n * (raw_params + 3) + 4 + 2 * n * kShRest : 4 * n * kParamFloats;
  bytes += half_m ? 2 * (5 * 4 + 2 * n * kParamFloats) : 2 * 4 * n * kParamFloats;
  return bytes;
}

ChunkEncoder::ChunkEncoder(const GaussianBlock& cb, uint32_t flags) {
  auto& b = const_cast<GaussianBlock&>(cb);  // only read through these pointers
  for (const Field& f : fields_of(b, flags)) {
    if (f.kind == Kind::Raw) {
      arrays_.push_back({static_cast<uint8_t*>(f.raw), 4 * f.elements, 4});
      continue;
    }
    owned_.emplace_back(stored_bytes(f));
    encode(f, owned_.back().data());
    arrays_.push_back({owned_.back().data(), owned_.back().size(), f.kind == Kind::ShDc ? 4 : 2});
  }
}

ChunkDecoder::ChunkDecoder(GaussianBlock& block, uint32_t flags) : block_(block), flags_(flags) {
  const auto fields = fields_of(block, flags);
  for (size_t k = 0; k < fields.size(); ++k) {
    const Field& f = fields[k];
    if (f.kind == Kind::Raw) {
      arrays_.push_back({static_cast<uint8_t*>(f.raw), 4 * f.elements, 4});
      continue;
    }
    owned_.emplace_back(stored_bytes(f));
    steps_.emplace_back(owned_.size() - 1, int(k));
    arrays_.push_back({owned_.back().data(), owned_.back().size(), f.kind == Kind::ShDc ? 4 : 2});
  }
}

void ChunkDecoder::finish() {
  const auto fields = fields_of(block_, flags_);
  for (const auto& [buffer, field] : steps_) decode(fields[size_t(field)], owned_[buffer].data());
}

}  // namespace chungs
