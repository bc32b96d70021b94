#include "chungs/eval/lpips_weights.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>

#include "chungs/common/error.hpp"

namespace chungs {

static_assert(std::endian::native == std::endian::little, "DCLPIPS1 tensors are read as they lie in memory");

namespace {

// AlexNet's features are ~2.5 M floats (10 MB); anything far beyond is not such a file, and the
// bound keeps a hostile file from being read into memory whole.
constexpr uintmax_t kMaxFileBytes = uintmax_t(64) << 20;
constexpr uint32_t kMaxNameBytes = 256;
constexpr uint32_t kMaxDims = 8;

std::string shape_text(const std::vector<uint32_t>& s) {
  std::string t = "[";
  for (size_t i = 0; i < s.size(); ++i) t += (i ? ", " : "") + std::to_string(s[i]);
  return t + "]";
}

// Every read is bounded by what is left before the checksum, so no size in the file can make the
// reader allocate more than the file holds.
class Cursor {
 public:
  Cursor(const std::string& bytes, size_t end, const std::filesystem::path& file)
      : bytes_(bytes), end_(end), file_(file) {}
  size_t left() const { return end_ - pos_; }
  size_t pos() const { return pos_; }
  uint32_t u32(const std::string& what) {
    need(4, what);
    uint32_t v;
    std::memcpy(&v, bytes_.data() + pos_, 4);
    pos_ += 4;
    return v;
  }
  std::string text(size_t n, const std::string& what) {
    need(n, what);
    std::string s = bytes_.substr(pos_, n);
    pos_ += n;
    return s;
  }
  std::vector<float> floats(uint64_t n, const std::string& what) {
    if (n > left() / 4)
      fail(file_.string(), ": truncated LPIPS weights: ", what, " declares ", n, " floats but only ", left(),
           " bytes are left");
    std::vector<float> v(n);
    std::memcpy(v.data(), bytes_.data() + pos_, n * 4);
    pos_ += n * 4;
    return v;
  }

 private:
  void need(size_t n, const std::string& what) {
    if (n > left()) fail(file_.string(), ": truncated LPIPS weights: ", what, " needs ", n, " bytes, ", left(), " left");
  }
  const std::string& bytes_;
  size_t pos_ = 0, end_;
  const std::filesystem::path& file_;
};

std::string read_bytes(const std::filesystem::path& file) {
  require_file(file, "LPIPS weights file");
  std::error_code ec;
  const uintmax_t size = std::filesystem::file_size(file, ec);
  if (ec) fail(file.string(), ": cannot read its size (", ec.message(), ")");
  if (size > kMaxFileBytes)
    fail(file.string(), ": ", size, " bytes is far more than LPIPS weights take (", kMaxFileBytes, " at most)");
  std::ifstream in(file, std::ios::binary);
  if (!in) fail(file.string(), ": cannot open");
  std::string bytes(size_t(size), '\0');
  in.read(bytes.data(), std::streamsize(size));
  if (in.gcount() != std::streamsize(size)) fail(file.string(), ": read failed");
  return bytes;
}

void put_u32(std::string& out, uint32_t v) { out.append(reinterpret_cast<const char*>(&v), 4); }

}  // namespace

uint32_t crc32(const void* data, size_t len, uint32_t crc) {
  static const auto table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  const auto* p = static_cast<const unsigned char*>(data);
  crc = ~crc;
  for (size_t i = 0; i < len; ++i) crc = table[(crc ^ p[i]) & 0xFFu] ^ (crc >> 8);
  return ~crc;
}

std::vector<LpipsTensorSpec> lpips_tensor_specs() {
  std::vector<LpipsTensorSpec> specs;
  for (const auto& c : kAlexConv) {
    const std::string base = "features." + std::to_string(c.torch_index);
    specs.push_back({base + ".weight", {uint32_t(c.out), uint32_t(c.in), uint32_t(c.kernel), uint32_t(c.kernel)}});
    specs.push_back({base + ".bias", {uint32_t(c.out)}});
  }
  for (size_t l = 0; l < kAlexConv.size(); ++l)
    specs.push_back({"lin" + std::to_string(l) + ".weight", {1, uint32_t(kAlexConv[l].out), 1, 1}});
  return specs;
}

LpipsWeights read_lpips_weights(const std::filesystem::path& file) {
  const std::string bytes = read_bytes(file);
  const std::string f = file.string();
  if (bytes.size() < sizeof kLpipsMagic || std::memcmp(bytes.data(), kLpipsMagic, sizeof kLpipsMagic) != 0)
    fail(f, ": not an LPIPS weights file (no DCLPIPS1 header; convert the published weights with "
            "scripts/lpips_convert.py)");
  if (bytes.size() < sizeof kLpipsMagic + 12) fail(f, ": truncated LPIPS weights (", bytes.size(), " bytes)");
  Cursor cur(bytes, bytes.size() - 4, file);
  cur.text(sizeof kLpipsMagic, "the header");
  const uint32_t version = cur.u32("the version");
  if (version != kLpipsFormatVersion)
    fail(f, ": LPIPS weights format version ", version, ", this build reads version ", kLpipsFormatVersion);
  const auto specs = lpips_tensor_specs();
  const uint32_t count = cur.u32("the tensor count");
  if (count != specs.size()) fail(f, ": ", count, " tensors, LPIPS 'alex' has ", specs.size());

  std::vector<std::vector<float>> data;
  for (const auto& spec : specs) {
    const uint32_t name_len = cur.u32("a tensor name's length");
    if (name_len > kMaxNameBytes) fail(f, ": tensor name of ", name_len, " bytes (expected ", spec.name, ")");
    const std::string name = cur.text(name_len, "a tensor name");
    if (name != spec.name) fail(f, ": tensor '", name, "' where '", spec.name, "' belongs");
    const uint32_t ndim = cur.u32(name + "'s rank");
    if (ndim > kMaxDims) fail(f, ": tensor ", name, " has ", ndim, " dimensions");
    std::vector<uint32_t> shape(ndim);
    uint64_t n = 1;
    for (auto& d : shape) {
      d = cur.u32(name + "'s shape");
      // Capped so the product cannot overflow before it is compared with the bytes left.
      n = std::min<uint64_t>(n * d, uint64_t(1) << 40);
    }
    if (shape != spec.shape)
      fail(f, ": tensor ", name, " has shape ", shape_text(shape), ", expected ", shape_text(spec.shape));
    data.push_back(cur.floats(n, "tensor " + name));
    for (float v : data.back())
      if (!std::isfinite(v)) fail(f, ": tensor ", name, " holds a non-finite value");
  }
  if (cur.left() != 0) fail(f, ": ", cur.left(), " bytes after the last tensor");
  uint32_t stored;
  std::memcpy(&stored, bytes.data() + bytes.size() - 4, 4);
  if (crc32(bytes.data(), bytes.size() - 4) != stored) fail(f, ": LPIPS weights damaged (checksum mismatch)");

  LpipsWeights w;
  for (size_t l = 0; l < kAlexConv.size(); ++l) {
    w.conv[l].weight = std::move(data[2 * l]);
    w.conv[l].bias = std::move(data[2 * l + 1]);
    w.lin[l] = std::move(data[2 * kAlexConv.size() + l]);
    for (float v : w.lin[l])
      if (v < 0) fail(f, ": lin", l, ".weight has a negative weight ", v, " (LPIPS heads are non-negative)");
  }
  return w;
}

std::string lpips_weights_bytes(const LpipsWeights& w) {
  const auto specs = lpips_tensor_specs();
  std::vector<const std::vector<float>*> tensors;
  for (const auto& c : w.conv) tensors.push_back(&c.weight), tensors.push_back(&c.bias);
  for (const auto& l : w.lin) tensors.push_back(&l);
  std::string out(kLpipsMagic, sizeof kLpipsMagic);
  put_u32(out, kLpipsFormatVersion);
  put_u32(out, uint32_t(specs.size()));
  for (size_t i = 0; i < specs.size(); ++i) {
    size_t n = 1;
    for (uint32_t d : specs[i].shape) n *= d;
    if (tensors[i]->size() != n) fail("LPIPS weights: ", specs[i].name, " has ", tensors[i]->size(), " values, not ", n);
    put_u32(out, uint32_t(specs[i].name.size()));
    out += specs[i].name;
    put_u32(out, uint32_t(specs[i].shape.size()));
    for (uint32_t d : specs[i].shape) put_u32(out, d);
    out.append(reinterpret_cast<const char*>(tensors[i]->data()), n * 4);
  }
  put_u32(out, crc32(out.data(), out.size()));
  return out;
}

void write_lpips_weights(const std::filesystem::path& file, const LpipsWeights& w) {
  const std::string bytes = lpips_weights_bytes(w);
  std::ofstream out(file, std::ios::binary);
  if (!out) fail(file.string(), ": cannot open for writing");
  out.write(bytes.data(), std::streamsize(bytes.size()));
  out.flush();
  if (!out) fail(file.string(), ": write failed");
}

}  // namespace chungs
