#include "chungs/store/chunk_codec.hpp"

#include <cmath>
#include <cstring>
#include <limits>

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

// The field's values in file order (SH split by coefficient), as a contiguous array.
void gather(const Field& f, std::vector<float>& out) {
  out.resize(f.elements);
  if (f.kind == Kind::ShDc || f.kind == Kind::ShRest) {
    const int first = f.kind == Kind::ShDc ? 0 : 3, count = f.kind == Kind::ShDc ? 3 : kShRest;
    const size_t gaussians = f.elements / size_t(count);
    for (size_t g = 0; g < gaussians; ++g)
      std::memcpy(&out[g * size_t(count)], f.f + g * kShFloats + first, sizeof(float) * size_t(count));
  } else if (f.kind == Kind::HalfSqrt) {
    signed_sqrt(f.f, out.data(), f.elements);
  } else {
    std::memcpy(out.data(), f.f, sizeof(float) * f.elements);
  }
}

void scatter(const Field& f, const std::vector<float>& in) {
  if (f.kind == Kind::ShDc || f.kind == Kind::ShRest) {
    const int first = f.kind == Kind::ShDc ? 0 : 3, count = f.kind == Kind::ShDc ? 3 : kShRest;
    const size_t gaussians = f.elements / size_t(count);
    for (size_t g = 0; g < gaussians; ++g)
      std::memcpy(f.f + g * kShFloats + first, &in[g * size_t(count)], sizeof(float) * size_t(count));
  } else if (f.kind == Kind::HalfSqrt) {
    for (size_t i = 0; i < f.elements; ++i) f.f[i] = in[i] * std::fabs(in[i]);
  } else {
    std::memcpy(f.f, in.data(), sizeof(float) * f.elements);
  }
}

// Scratch arrays reused across chunks: fresh ones per array cost more in page faults and
// zeroing than the conversion itself.
std::vector<float>& scratch_floats() {
  thread_local std::vector<float> v;
  return v;
}

void encode(const Field& f, uint8_t* out) {
  // Contiguous moments are converted in place; v's square roots and the SH split need a copy.
  const float* values = f.f;
  if (f.kind != Kind::Half) {
    gather(f, scratch_floats());
    values = scratch_floats().data();
  }
  if (f.kind == Kind::ShDc) {
    std::memcpy(out, values, 4 * f.elements);
    return;
  }
  const float largest = max_finite_abs(values, f.elements);
  int e = 0;
  std::frexp(largest, &e);  // largest < 2^e
  const float scale = largest > 0 ? std::ldexp(1.0f, e - 15) : 1.0f;
  std::memcpy(out, &scale, 4);
  scaled_floats_to_halves(values, 1.0f / scale, out + 4, f.elements);  // 1/scale: exact, a power of two
  if (f.kind == Kind::HalfSqrt) keep_nonzero(f.f, out + 4, f.elements);
}

void decode(const Field& f, const uint8_t* in) {
  float scale = 1;
  if (f.kind != Kind::ShDc) std::memcpy(&scale, in, 4);
  if (f.kind == Kind::Half) {
    halves_to_scaled_floats(in + 4, scale, f.f, f.elements);
    return;
  }
  std::vector<float>& values = scratch_floats();
  values.resize(f.elements);
  if (f.kind == Kind::ShDc)
    std::memcpy(values.data(), in, 4 * f.elements);
  else
    halves_to_scaled_floats(in + 4, scale, values.data(), f.elements);
  scatter(f, values);
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
    owned_.push_back(std::make_unique_for_overwrite<uint8_t[]>(stored_bytes(f)));
    encode(f, owned_.back().get());
    arrays_.push_back({owned_.back().get(), stored_bytes(f), f.kind == Kind::ShDc ? 4 : 2});
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
    owned_.push_back(std::make_unique_for_overwrite<uint8_t[]>(stored_bytes(f)));
    steps_.emplace_back(owned_.size() - 1, int(k));
    arrays_.push_back({owned_.back().get(), stored_bytes(f), f.kind == Kind::ShDc ? 4 : 2});
  }
}

void ChunkDecoder::finish() {
  const auto fields = fields_of(block_, flags_);
  for (const auto& [buffer, field] : steps_) decode(fields[size_t(field)], owned_[buffer].get());
}

}  // namespace chungs
