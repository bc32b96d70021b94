#include "chungs/store/chunk_codec.hpp"

#include <cmath>
#include <algorithm>
#include <cstring>
#include <limits>
#include <vector>

#include "chungs/common/mapped_allocator.hpp"
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
  size_t per;       // of them a Gaussian
};

// The file order of the version 1 layout (the arrays' own order), with SH and moments switched to
// their encodings.
std::vector<Field> fields_of(const BlockArrays& b, uint32_t flags) {
  const size_t n = b.count;
  std::vector<Field> out;
  for (int a = 0; a < kBlockArrays; ++a) {
    void* data = b.data[size_t(a)];
    float* f = static_cast<float*>(data);
    const size_t width = size_t(kBlockArrayWidths[size_t(a)]);
    const int group = a < kBlockFirstWord ? a / kBlockArraysPerGroup : -1;  // params, m, v; -1: words
    const bool moment = group == 1 || group == 2;
    const bool sh = group == 0 && a % kBlockArraysPerGroup == kBlockGroupSh;
    if (moment && (flags & kChunkFlagHalfMoments)) {
      out.push_back({group == 2 ? Kind::HalfSqrt : Kind::Half, f, nullptr, b.values(a), width});
    } else if (sh && (flags & kChunkFlagHalfShRest)) {
      out.push_back({Kind::ShDc, f, nullptr, 3 * n, 3});
      out.push_back({Kind::ShRest, f, nullptr, size_t(kShRest) * n, size_t(kShRest)});
    } else {
      out.push_back({Kind::Raw, nullptr, data, b.values(a), width});
    }
  }
  return out;
}

// A block to be only read, as fields_of takes it.
BlockArrays read_only(const ConstBlockArrays& cb) {
  BlockArrays b;
  b.count = cb.count;
  b.sh_degree = cb.sh_degree;
  for (int a = 0; a < kBlockArrays; ++a) b.data[size_t(a)] = const_cast<void*>(cb.data[size_t(a)]);
  return b;
}

// Gaussians converted at a time. A thread's buffers are bounded by this, not by the largest chunk
// it ever converted: whole-chunk copies left 16 I/O threads holding 96 MB of heap after chunks of
// 10 k Gaussians (bench/README.md, issue 19).
constexpr size_t kPieceGaussians = 2048;
constexpr size_t kPieceValues =  // the widest field's
    kPieceGaussians * size_t(*std::max_element(kBlockArrayWidths.begin(), kBlockArrayWidths.end()));

// A thread's buffers for one piece: values in file order, and their encoding. They and the file
// buffers (chunk_file.cpp, zstd_stream.cpp) are mapped, not taken from the heap: a checkpoint's writer
// threads are made for it and end with it, and between checkpoints other blocks took the heap holes
// their buffers left, so every checkpoint took fresh heap (a 5 km CPU drive: the heap grew 17 MB after
// the budget was full; 7 MB with the buffers mapped; bench/README.md).
float* piece_floats() {
  thread_local MappedVector<float> v(kPieceValues);
  return v.data();
}
// One byte of each value of a piece (a plane of the byte shuffle).
uint8_t* plane_bytes() {
  thread_local MappedVector<uint8_t> v(kPieceValues);
  return v.data();
}
uint8_t* piece_bytes() {
  // Halves of the widest field, or the 3 float32 DC values a Gaussian: 2 bytes a value is enough.
  static_assert(3 * 4 <= 2 * kPieceValues / kPieceGaussians);
  thread_local MappedVector<uint8_t> v(2 * kPieceValues);
  return v.data();
}

// Values [begin, end) of the field in file order (SH split by coefficient; begin and end whole
// Gaussians), into out.
void gather(const Field& f, size_t begin, size_t end, float* out) {
  if (f.kind == Kind::ShDc || f.kind == Kind::ShRest) {
    const size_t first = f.kind == Kind::ShDc ? 0 : 3;
    for (size_t g = begin / f.per; g < end / f.per; ++g)
      std::memcpy(out + (g * f.per - begin), f.f + g * kShFloats + first, sizeof(float) * f.per);
  } else if (f.kind == Kind::HalfSqrt) {
    signed_sqrt(f.f + begin, out, end - begin);
  } else {
    std::memcpy(out, f.f + begin, sizeof(float) * (end - begin));
  }
}

void scatter(const Field& f, size_t begin, size_t end, const float* in) {
  if (f.kind == Kind::ShDc || f.kind == Kind::ShRest) {
    const size_t first = f.kind == Kind::ShDc ? 0 : 3;
    for (size_t g = begin / f.per; g < end / f.per; ++g)
      std::memcpy(f.f + g * kShFloats + first, in + (g * f.per - begin), sizeof(float) * f.per);
  } else if (f.kind == Kind::HalfSqrt) {
    for (size_t i = begin; i < end; ++i) f.f[i] = in[i - begin] * std::fabs(in[i - begin]);
  } else {
    std::memcpy(f.f + begin, in, sizeof(float) * (end - begin));
  }
}

// calls f(begin, end) over the field's values a piece at a time
template <class F>
void by_piece(const Field& field, F&& f) {
  const size_t step = kPieceGaussians * field.per;
  for (size_t begin = 0; begin < field.elements; begin += step) f(begin, std::min(field.elements, begin + step));
}

// The power of two that maps the field's largest finite magnitude just under 2^15.
float scale_of(const Field& f) {
  float largest = 0;
  if (f.kind == Kind::Half) {  // contiguous: no copy
    largest = max_finite_abs(f.f, f.elements);
  } else {
    by_piece(f, [&](size_t begin, size_t end) {
      gather(f, begin, end, piece_floats());
      largest = std::max(largest, max_finite_abs(piece_floats(), end - begin));
    });
  }
  int e = 0;
  std::frexp(largest, &e);  // largest < 2^e
  return largest > 0 ? std::ldexp(1.0f, e - 15) : 1.0f;
}

// Values [begin, end) of an encoded field as stored (after the scale, for the halves).
void encode_range(const Field& f, float scale, size_t begin, size_t end, uint8_t* out) {
  const size_t n = end - begin;
  // Contiguous moments are converted in place; v's square roots and the SH split need a copy.
  const float* values = f.f + begin;
  if (f.kind != Kind::Half) {
    gather(f, begin, end, piece_floats());
    values = piece_floats();
  }
  if (f.kind == Kind::ShDc) {
    std::memcpy(out, values, 4 * n);
    return;
  }
  scaled_floats_to_halves(values, 1.0f / scale, out, n);  // 1/scale: exact, a power of two
  if (f.kind == Kind::HalfSqrt) keep_nonzero(f.f + begin, out, n);
}

void decode_range(const Field& f, float scale, size_t begin, size_t end, const uint8_t* in) {
  const size_t n = end - begin;
  if (f.kind == Kind::Half) {
    halves_to_scaled_floats(in, scale, f.f + begin, n);
    return;
  }
  float* values = piece_floats();
  if (f.kind == Kind::ShDc)
    std::memcpy(values, in, 4 * n);
  else
    halves_to_scaled_floats(in, scale, values, n);
  scatter(f, begin, end, values);
}

size_t value_bytes(const Field& f) { return f.kind == Kind::ShDc ? 4 : 2; }

// Where value i of an encoded field (file order) lives in the block.
float* slot(const Field& f, size_t i) {
  if (f.kind == Kind::ShDc) return f.f + (i / 3) * kShFloats + i % 3;
  if (f.kind == Kind::ShRest) return f.f + (i / kShRest) * kShFloats + 3 + i % kShRest;
  return f.f + i;
}
uint8_t& byte_of(float* value, int b) { return reinterpret_cast<uint8_t*>(value)[b]; }

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

void encode_payload(const ConstBlockArrays& cb, uint32_t flags, const std::function<void(const void*, size_t)>& emit) {
  for (const Field& f : fields_of(read_only(cb), flags)) {
    if (f.kind == Kind::Raw) {
      emit(f.raw, 4 * f.elements);
      continue;
    }
    float scale = 1;
    if (f.kind != Kind::ShDc) {
      scale = scale_of(f);
      emit(&scale, 4);
    }
    by_piece(f, [&](size_t begin, size_t end) {
      encode_range(f, scale, begin, end, piece_bytes());
      emit(piece_bytes(), value_bytes(f) * (end - begin));
    });
  }
}

void decode_payload(const BlockArrays& block, uint32_t flags, const std::function<void(void*, size_t)>& read) {
  for (const Field& f : fields_of(block, flags)) {
    if (f.kind == Kind::Raw) {
      read(f.raw, 4 * f.elements);
      continue;
    }
    float scale = 1;
    if (f.kind != Kind::ShDc) read(&scale, 4);
    by_piece(f, [&](size_t begin, size_t end) {
      read(piece_bytes(), value_bytes(f) * (end - begin));
      decode_range(f, scale, begin, end, piece_bytes());
    });
  }
}

void encode_shuffled_payload(const ConstBlockArrays& cb, uint32_t flags,
                             const std::function<void(const void*, size_t)>& emit) {
  for (const Field& f : fields_of(read_only(cb), flags)) {
    uint8_t* plane = plane_bytes();
    if (f.kind == Kind::Raw) {
      const auto* bytes = static_cast<const uint8_t*>(f.raw);
      for (int b = 0; b < 4; ++b)
        by_piece(f, [&](size_t begin, size_t end) {
          for (size_t i = begin; i < end; ++i) plane[i - begin] = bytes[4 * i + size_t(b)];
          emit(plane, end - begin);
        });
      continue;
    }
    const size_t w = value_bytes(f);
    float scale = 1;
    uint8_t s[4] = {};
    if (f.kind != Kind::ShDc) {
      scale = scale_of(f);
      std::memcpy(s, &scale, 4);
    }
    // Each plane encodes the values again: a pass more over a piece, where holding the encoded array
    // would cost its size for every thread.
    for (size_t b = 0; b < w; ++b) {
      if (f.kind != Kind::ShDc) {
        const uint8_t head[2] = {s[b], s[2 + b]};
        emit(head, 2);
      }
      by_piece(f, [&](size_t begin, size_t end) {
        encode_range(f, scale, begin, end, piece_bytes());
        const uint8_t* values = piece_bytes();
        for (size_t i = 0; i < end - begin; ++i) plane[i] = values[w * i + b];
        emit(plane, end - begin);
      });
    }
  }
}

void decode_shuffled_payload(const BlockArrays& block, uint32_t flags, const std::function<void(void*, size_t)>& read) {
  for (const Field& f : fields_of(block, flags)) {
    uint8_t* plane = plane_bytes();
    if (f.kind == Kind::Raw || f.kind == Kind::ShDc) {  // 4-byte values: each byte straight to its place
      for (int b = 0; b < 4; ++b)
        by_piece(f, [&](size_t begin, size_t end) {
          read(plane, end - begin);
          if (f.kind == Kind::Raw) {
            auto* bytes = static_cast<uint8_t*>(f.raw);
            for (size_t i = begin; i < end; ++i) bytes[4 * i + size_t(b)] = plane[i - begin];
          } else {
            for (size_t i = begin; i < end; ++i) byte_of(slot(f, i), b) = plane[i - begin];
          }
        });
      continue;
    }
    uint8_t s[4], head[2];
    read(head, 2);
    s[0] = head[0], s[2] = head[1];
    by_piece(f, [&](size_t begin, size_t end) {
      read(plane, end - begin);
      for (size_t i = begin; i < end; ++i) byte_of(slot(f, i), 0) = plane[i - begin];
    });
    read(head, 2);
    s[1] = head[0], s[3] = head[1];
    float scale;
    std::memcpy(&scale, s, 4);
    by_piece(f, [&](size_t begin, size_t end) {
      read(plane, end - begin);
      uint8_t* halves = piece_bytes();
      for (size_t i = begin; i < end; ++i) {
        halves[2 * (i - begin)] = byte_of(slot(f, i), 0);
        halves[2 * (i - begin) + 1] = plane[i - begin];
      }
      decode_range(f, scale, begin, end, halves);
    });
  }
}

}  // namespace chungs
