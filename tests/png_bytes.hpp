// PNG files built byte by byte, for tests that need what the writer never makes: a header declaring
// more than the file holds, or a large image written without holding its pixels in memory.
#pragma once
#include <zlib.h>

#include <cstdint>
#include <string>

namespace chungs::test {

inline void put_be32(std::string& s, uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) s += char((v >> shift) & 0xff);
}

inline void add_png_chunk(std::string& png, const std::string& type, const std::string& data) {
  put_be32(png, uint32_t(data.size()));
  const std::string body = type + data;
  png += body;
  put_be32(png, uint32_t(crc32(0, reinterpret_cast<const Bytef*>(body.data()), uInt(body.size()))));
}

// An 8-bit PNG (colour type 0 gray, 2 RGB, 6 RGBA) declaring width x height, whose image data holds
// the first `rows` rows, all zero (rows == height: a complete image).
inline std::string png_of_zeros(uint32_t width, uint32_t height, char colour_type, uint32_t rows) {
  const size_t channels = colour_type == 0 ? 1 : colour_type == 2 ? 3 : 4;
  std::string png("\x89PNG\r\n\x1a\n", 8), ihdr;
  put_be32(ihdr, width);
  put_be32(ihdr, height);
  ihdr += std::string{'\x08', colour_type, '\0', '\0', '\0'};
  add_png_chunk(png, "IHDR", ihdr);
  std::string row(1 + width * channels, '\0'), packed(1 << 16, '\0'), idat;  // filter byte 0, then samples
  z_stream z{};
  deflateInit(&z, Z_BEST_COMPRESSION);
  for (uint32_t r = 0; r <= rows; ++r) {
    const bool last = r == rows;
    z.next_in = reinterpret_cast<Bytef*>(row.data());
    z.avail_in = last ? 0 : uInt(row.size());
    int ret;
    do {
      z.next_out = reinterpret_cast<Bytef*>(packed.data());
      z.avail_out = uInt(packed.size());
      ret = deflate(&z, last ? Z_FINISH : Z_NO_FLUSH);
      idat.append(packed.data(), packed.size() - z.avail_out);
    } while (last ? ret != Z_STREAM_END : z.avail_in > 0);
  }
  deflateEnd(&z);
  add_png_chunk(png, "IDAT", idat);
  add_png_chunk(png, "IEND", "");
  return png;
}

}  // namespace chungs::test
