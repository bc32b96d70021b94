// One keyframe's images as one file: a colour image (8-bit, 1-4 channels) and an optional depth
// map (float metres, 1 channel), with a header (magic "CHGSKFRM", version, keyframe id, shapes,
// flags, payload sizes, payload and header XXH64) and an optionally zstd-compressed payload.
// Written crash-safely like chunk files; a reader rejects anything inconsistent, naming the file.
#pragma once
#include <cstdint>
#include <filesystem>

#include "chungs/image/image.hpp"

namespace chungs {

constexpr uint32_t kKeyframeFormatVersion = 1;

struct KeyframeImages {
  Image8 color;
  ImageF depth;  // empty when the keyframe has no depth

  size_t bytes() const { return color.size() + depth.size() * sizeof(float); }
};

struct KeyframeWriteOptions {
  bool compress = true;  // depth maps and images shrink; keyframes are written once, read often
  int zstd_level = 1;
  bool durable = true;
};

// Returns the bytes written.
uint64_t write_keyframe_file(const std::filesystem::path& file, uint64_t id, const KeyframeImages& images,
                             const KeyframeWriteOptions& options);
// Returns the keyframe id found in the header.
uint64_t read_keyframe_file(const std::filesystem::path& file, KeyframeImages& out, uint64_t* bytes_read = nullptr);

}  // namespace chungs
