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

// The file order of the version 1 layout (the arrays' own order), with SH and moments switched to
// their encodings.
std::vector<Field> fields_of(const BlockArrays& b, uint32_t flags) {
  const size_t n = b.count;
  std::vector<Field> out;
  for (int a = 0; a < kBlockArrays; ++a) {
    void* data = b.data[size_t(a)];
    float* f = static_cast<float*>(data);
    const int group = a < kBlockFirstWord ? a / kBlockArraysPerGroup : -1;  // params, m, v; -1: words
    const bool moment = group == 1 || group == 2;
    const bool sh = group == 0 && a % kBlockArraysPerGroup == kBlockGroupSh;
    if (moment && (flags & kChunkFlagHalfMoments)) {
      out.push_back({group == 2 ? Kind::HalfSqrt : Kind::Half, f, nullptr, b.values(a)});
    } else if (sh && (flags & kChunkFlagHalfShRest)) {
      out.push_back({Kind::ShDc, f, nullptr, 3 * n});
      out.push_back({Kind::ShRest, f, nullptr, size_t(kShRest) * n});
    } else {
      out.push_back({Kind::Raw, nullptr, data, b.values(a)});
    }
  }
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

ChunkEncoder::ChunkEncoder(const ConstBlockArrays& cb, uint32_t flags) {
  BlockArrays b;  // only read through these pointers
  b.count = cb.count;
  b.sh_degree = cb.sh_degree;
  for (int a = 0; a < kBlockArrays; ++a) b.data[size_t(a)] = const_cast<void*>(cb.data[size_t(a)]);
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

ChunkDecoder::ChunkDecoder(const BlockArrays& block, uint32_t flags) : block_(block), flags_(flags) {
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
