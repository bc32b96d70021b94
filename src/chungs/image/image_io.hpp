// PNG (8/16-bit) and JPEG files through libpng and libjpeg directly (not OpenCV imgcodecs: it
// pulls GDAL and ~150 libraries into the binary's closure, see DESIGN.md).
#pragma once
#include <filesystem>

#include "chungs/image/image.hpp"

namespace chungs {

// Reads a PNG or JPEG (by content, not extension) as 8-bit with the file's channels (1, 3 or 4;
// palette expanded, gray+alpha dropped to gray). 16-bit PNGs are reduced to their high byte. A
// header declaring more than kMaxImagePixels, or more image data than the file's length can hold,
// is refused before the pixels are allocated.
Image8 read_image8(const std::filesystem::path& file);
// Reads a 1-channel 16-bit PNG: depth maps. An 8-bit file is refused (it cannot hold depth units).
Image16 read_png16(const std::filesystem::path& file);

// Writers create parent folders; an existing file is replaced.
void write_png(const std::filesystem::path& file, const Image8& img);
void write_png(const std::filesystem::path& file, const Image16& img);  // 1 channel
void write_jpeg(const std::filesystem::path& file, const Image8& img, int quality = 95);  // 1 or 3 ch
// Writes by extension: .png or .jpg/.jpeg.
void write_image(const std::filesystem::path& file, const Image8& img);

}  // namespace chungs
