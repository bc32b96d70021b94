#include "chungs/image/image_io.hpp"

#include <jpeglib.h>
#include <png.h>

#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>

#include "chungs/common/error.hpp"
#include "chungs/common/text_file.hpp"

namespace chungs {

namespace {

// libpng and libjpeg report errors by longjmp. Everything between setjmp and a possible longjmp is
// plain data owned outside these functions, so no destructor is skipped; we throw afterwards.
struct ErrBuf {
  std::jmp_buf jmp;
  char msg[JMSG_LENGTH_MAX + 256] = {0};
  bool refused = false;  // msg says why a well-formed header was refused, not what is corrupt
};

// Deflate expands at most 1032:1 (a 258-byte match coded in 2 bits): PNG image data of N bytes needs
// at least N / 1032 bytes of file.
constexpr uint64_t kMaxDeflateExpansion = 1032;

// Returns false with the reason in err when a header declares more pixels than any image may have,
// or more image data than `file_bytes` can hold (`least_file_bytes`): a 100-byte PNG declaring
// 100000x100000 once took 9.8 GB before its data ran out. Runs between setjmp and longjmp, where no
// object with a destructor may be alive: it formats into err's buffer.
bool declared_size_ok(const char* format, uint64_t width, uint64_t height, uint64_t least_file_bytes,
                      uint64_t file_bytes, ErrBuf& err) {
  const auto w = (unsigned long long)width, h = (unsigned long long)height;
  if (width * height > kMaxImagePixels)
    std::snprintf(err.msg, sizeof err.msg,
                  "%s header declares %llu x %llu pixels, more than the %llu an image may have", format, w, h,
                  (unsigned long long)kMaxImagePixels);
  else if (least_file_bytes > file_bytes)
    std::snprintf(
        err.msg, sizeof err.msg,
        "%s header declares %llu x %llu pixels, whose data needs at least %llu bytes; the file has %llu",
        format, w, h, (unsigned long long)least_file_bytes, (unsigned long long)file_bytes);
  else
    return true;
  err.refused = true;
  return false;
}

void png_err(png_structp png, png_const_charp msg) {
  auto* e = static_cast<ErrBuf*>(png_get_error_ptr(png));
  std::snprintf(e->msg, sizeof e->msg, "%s", msg);
  std::longjmp(e->jmp, 1);
}
void png_warn(png_structp, png_const_charp) {}

struct MemReader {
  const unsigned char* data;
  size_t size, pos;
};
void png_read_mem(png_structp png, png_bytep out, png_size_t n) {
  auto* r = static_cast<MemReader*>(png_get_io_ptr(png));
  if (r->pos + n > r->size) png_error(png, "file is truncated");
  std::memcpy(out, r->data + r->pos, n);
  r->pos += n;
}

struct PngPixels {
  int width = 0, height = 0, channels = 0, bit_depth = 0;
  std::vector<unsigned char> bytes;  // rows as libpng delivers them (16-bit big-endian)
};

// Decodes a PNG after expanding palette/low-bit gray and dropping gray alpha; keeps 16-bit samples.
bool decode_png(const std::string& file_bytes, PngPixels& out, ErrBuf& err) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &err, png_err, png_warn);
  if (!png) {
    std::snprintf(err.msg, sizeof err.msg, "cannot create PNG decoder");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  MemReader reader{reinterpret_cast<const unsigned char*>(file_bytes.data()), file_bytes.size(), 0};
  std::vector<png_bytep>* rows = new std::vector<png_bytep>();
  if (setjmp(err.jmp)) {
    png_destroy_read_struct(&png, &info, nullptr);
    delete rows;
    return false;
  }
  png_set_read_fn(png, &reader, png_read_mem);
  png_read_info(png, info);
  {  // before any transform: the samples as the file stores them (a palette index is one)
    const uint64_t w = png_get_image_width(png, info), h = png_get_image_height(png, info);
    const uint64_t data_bytes = w * h * png_get_channels(png, info) * png_get_bit_depth(png, info) / 8;
    if (!declared_size_ok("PNG", w, h, data_bytes / kMaxDeflateExpansion, file_bytes.size(), err))
      std::longjmp(err.jmp, 1);
  }
  int color = png_get_color_type(png, info);
  int depth = png_get_bit_depth(png, info);
  if (color == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (color == PNG_COLOR_TYPE_GRAY && depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
  if (color == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_strip_alpha(png);
  png_read_update_info(png, info);
  out.width = int(png_get_image_width(png, info));
  out.height = int(png_get_image_height(png, info));
  out.channels = png_get_channels(png, info);
  out.bit_depth = png_get_bit_depth(png, info);
  size_t stride = png_get_rowbytes(png, info);
  out.bytes.resize(stride * out.height);
  rows->resize(out.height);
  for (int y = 0; y < out.height; ++y) (*rows)[y] = out.bytes.data() + stride * y;
  png_read_image(png, rows->data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  delete rows;
  return true;
}

// A refused header's reason stands alone; anything else the decoder stopped at is corruption.
[[noreturn]] void fail_decoding(const std::filesystem::path& file, const char* format, const ErrBuf& err) {
  if (err.refused) fail(file.string(), ": ", err.msg);
  fail(file.string(), ": corrupt ", format, " (", err.msg, ")");
}

PngPixels load_png(const std::filesystem::path& file, const std::string& bytes) {
  PngPixels px;
  ErrBuf err;
  if (!decode_png(bytes, px, err)) fail_decoding(file, "PNG", err);
  if (px.channels < 1 || px.channels > 4) fail(file.string(), ": unsupported PNG channel count ", px.channels);
  return px;
}

void jpeg_err_exit(j_common_ptr cinfo) {
  auto* e = static_cast<ErrBuf*>(cinfo->client_data);
  (*cinfo->err->format_message)(cinfo, e->msg);
  std::longjmp(e->jmp, 1);
}

bool decode_jpeg(const std::string& bytes, Image8& out, ErrBuf& err) {
  jpeg_decompress_struct cinfo;
  jpeg_error_mgr jerr;
  cinfo.err = jpeg_std_error(&jerr);
  jerr.error_exit = jpeg_err_exit;
  cinfo.client_data = &err;
  if (setjmp(err.jmp)) {
    jpeg_destroy_decompress(&cinfo);
    return false;
  }
  jpeg_create_decompress(&cinfo);
  jpeg_mem_src(&cinfo, reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size());
  jpeg_read_header(&cinfo, TRUE);
  {
    // Huffman coding spends at least one bit on every 8x8 block of every component (its DC
    // difference); arithmetic coding can spend less, so only the pixel limit holds for it.
    uint64_t blocks = 0;
    for (int c = 0; c < cinfo.num_components; ++c)
      blocks += uint64_t(cinfo.comp_info[c].width_in_blocks) * cinfo.comp_info[c].height_in_blocks;
    if (!declared_size_ok("JPEG", cinfo.image_width, cinfo.image_height, cinfo.arith_code ? 0 : blocks / 8,
                          bytes.size(), err))
      std::longjmp(err.jmp, 1);
  }
  if (cinfo.jpeg_color_space != JCS_GRAYSCALE) cinfo.out_color_space = JCS_RGB;
  jpeg_start_decompress(&cinfo);
  out = Image8(int(cinfo.output_width), int(cinfo.output_height), int(cinfo.output_components));
  while (cinfo.output_scanline < cinfo.output_height) {
    JSAMPROW row = out.row(int(cinfo.output_scanline));
    jpeg_read_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_decompress(&cinfo);
  jpeg_destroy_decompress(&cinfo);
  return true;
}

bool is_png(const std::string& b) { return b.size() >= 8 && std::memcmp(b.data(), "\x89PNG\r\n\x1a\n", 8) == 0; }
bool is_jpeg(const std::string& b) { return b.size() >= 3 && std::memcmp(b.data(), "\xff\xd8\xff", 3) == 0; }

}  // namespace

Image8 read_image8(const std::filesystem::path& file) {
  std::string bytes = read_file_text(file);
  if (is_jpeg(bytes)) {
    Image8 img;
    ErrBuf err;
    if (!decode_jpeg(bytes, img, err)) fail_decoding(file, "JPEG", err);
    return img;
  }
  if (!is_png(bytes)) fail(file.string(), ": not a PNG or JPEG file");
  PngPixels px = load_png(file, bytes);
  Image8 img(px.width, px.height, px.channels);
  size_t n = img.size();
  if (px.bit_depth == 16)
    for (size_t i = 0; i < n; ++i) img.data()[i] = px.bytes[2 * i];  // big-endian high byte
  else
    std::memcpy(img.data(), px.bytes.data(), n);
  return img;
}

Image16 read_png16(const std::filesystem::path& file) {
  std::string bytes = read_file_text(file);
  if (!is_png(bytes)) fail(file.string(), ": not a PNG file (16-bit depth must be PNG)");
  PngPixels px = load_png(file, bytes);
  if (px.channels != 1) fail(file.string(), ": expected a 1-channel (depth) PNG, found ", px.channels, " channels");
  // Read as depth units, 8-bit samples would put every surface within a few centimetres.
  if (px.bit_depth != 16)
    fail(file.string(), ": depth PNG has ", px.bit_depth, "-bit samples; depth maps must be 16-bit");
  Image16 img(px.width, px.height, 1);
  for (size_t i = 0; i < img.size(); ++i)
    img.data()[i] = uint16_t((px.bytes[2 * i] << 8) | px.bytes[2 * i + 1]);
  return img;
}

namespace {

void prepare_parent(const std::filesystem::path& file) {
  prepare_output_file(file, "image");
}

// Encodes into a temporary file beside `file` and renames it over `file` once whole, so that a failed
// write (a full disk) leaves the earlier file, or none, never a truncated or empty one.
// A link is followed (its target is replaced, not the link); a device or FIFO is written in place.
template <class Encode>
void write_whole(const std::filesystem::path& file, const char* kind, Encode encode) {
  prepare_parent(file);
  std::error_code ec;
  std::filesystem::path target = file;
  if (std::filesystem::is_symlink(file, ec)) target = std::filesystem::weakly_canonical(file, ec);
  if (ec) target = file;
  // Writing a FIFO waited for a reader that never came (a render hung on render_000000.png).
  if (std::filesystem::is_fifo(target, ec) || std::filesystem::is_socket(target, ec))
    fail(file.string(), ": is a FIFO or socket, not a file to write the ", kind, " to");
  const bool in_place = std::filesystem::exists(target, ec) && !std::filesystem::is_regular_file(target, ec);
  std::filesystem::path part = target;
  if (!in_place) part += ".part";
  FILE* f = std::fopen(part.c_str(), "wb");
  if (!f) fail(file.string(), ": cannot open for writing (", std::strerror(errno), ")");
  ErrBuf err;
  std::string why;
  if (!encode(f, err))
    why = cat(kind, " write failed (", err.msg, ")");
  else if (std::fflush(f) != 0)
    why = cat("write failed (", std::strerror(errno), ")");
  if (std::fclose(f) != 0 && why.empty()) why = cat("write failed (", std::strerror(errno), ")");
  if (!in_place && why.empty()) {
    std::filesystem::rename(part, target, ec);
    if (ec) why = cat("cannot replace it (", ec.message(), ")");
  }
  if (!why.empty()) {
    if (!in_place) std::filesystem::remove(part, ec);
    fail(file.string(), ": ", why);
  }
}

// libpng's own writer says only "Write Error"; the system's reason (a full disk, an I/O error) is
// what the user needs.
void png_write_file(png_structp png, png_bytep data, size_t n) {
  if (std::fwrite(data, 1, n, static_cast<FILE*>(png_get_io_ptr(png))) != n) png_error(png, std::strerror(errno));
}

void png_flush_file(png_structp png) {
  if (std::fflush(static_cast<FILE*>(png_get_io_ptr(png))) != 0) png_error(png, std::strerror(errno));
}

bool encode_png(FILE* f, int w, int h, int channels, int depth, const unsigned char* const* rows, ErrBuf& err) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &err, png_err, png_warn);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (setjmp(err.jmp)) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_set_write_fn(png, f, png_write_file, png_flush_file);
  // Fast zlib level: these are datasets and renders written in bulk, not archives.
  png_set_compression_level(png, 3);
  static const int types[] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB, PNG_COLOR_TYPE_RGBA};
  png_set_IHDR(png, info, w, h, depth, types[channels], PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  png_write_image(png, const_cast<png_bytepp>(rows));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

template <typename T>
void write_png_any(const std::filesystem::path& file, const Image<T>& img, int depth) {
  if (img.empty()) fail(file.string(), ": refusing to write an empty image");
  size_t stride = size_t(img.width()) * img.channels() * sizeof(T);
  std::vector<unsigned char> buf(stride * img.height());
  for (size_t i = 0; i < img.size(); ++i) {
    if constexpr (sizeof(T) == 2) {
      buf[2 * i] = uint8_t(img.data()[i] >> 8);
      buf[2 * i + 1] = uint8_t(img.data()[i] & 0xff);
    } else {
      buf[i] = img.data()[i];
    }
  }
  std::vector<const unsigned char*> rows(img.height());
  for (int y = 0; y < img.height(); ++y) rows[y] = buf.data() + stride * y;
  write_whole(file, "PNG", [&](FILE* f, ErrBuf& err) {
    return encode_png(f, img.width(), img.height(), img.channels(), depth, rows.data(), err);
  });
}

bool encode_jpeg(FILE* f, const Image8& img, int quality, ErrBuf& err) {
  jpeg_compress_struct cinfo;
  jpeg_error_mgr jerr;
  cinfo.err = jpeg_std_error(&jerr);
  jerr.error_exit = jpeg_err_exit;
  cinfo.client_data = &err;
  if (setjmp(err.jmp)) {
    jpeg_destroy_compress(&cinfo);
    return false;
  }
  jpeg_create_compress(&cinfo);
  jpeg_stdio_dest(&cinfo, f);
  cinfo.image_width = img.width();
  cinfo.image_height = img.height();
  cinfo.input_components = img.channels();
  cinfo.in_color_space = img.channels() == 1 ? JCS_GRAYSCALE : JCS_RGB;
  jpeg_set_defaults(&cinfo);
  jpeg_set_quality(&cinfo, quality, TRUE);
  jpeg_start_compress(&cinfo, TRUE);
  while (cinfo.next_scanline < cinfo.image_height) {
    JSAMPROW row = const_cast<JSAMPROW>(img.row(int(cinfo.next_scanline)));
    jpeg_write_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_compress(&cinfo);
  jpeg_destroy_compress(&cinfo);
  return true;
}

}  // namespace

void write_png(const std::filesystem::path& file, const Image8& img) { write_png_any(file, img, 8); }

void write_png(const std::filesystem::path& file, const Image16& img) {
  if (img.channels() != 1) fail(file.string(), ": 16-bit PNGs are written with 1 channel, got ", img.channels());
  write_png_any(file, img, 16);
}

void write_jpeg(const std::filesystem::path& file, const Image8& img, int quality) {
  if (img.empty()) fail(file.string(), ": refusing to write an empty image");
  if (img.channels() != 1 && img.channels() != 3)
    fail(file.string(), ": JPEG needs 1 or 3 channels, got ", img.channels());
  write_whole(file, "JPEG", [&](FILE* f, ErrBuf& err) { return encode_jpeg(f, img, quality, err); });
}

void write_image(const std::filesystem::path& file, const Image8& img) {
  std::string ext = file.extension().string();
  for (auto& c : ext) c = char(std::tolower(c));
  if (ext == ".png") return write_png(file, img);
  if (ext == ".jpg" || ext == ".jpeg") return write_jpeg(file, img);
  fail(file.string(), ": unknown image extension '", ext, "' (use .png or .jpg)");
}

}  // namespace chungs
