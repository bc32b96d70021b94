#include "chungs/synth/ply.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <string>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"

namespace chungs::synth {
namespace {

enum class Type { I8, U8, I16, U16, I32, U32, F32, F64 };

bool parse_type(const std::string& s, Type& t) {
  static const std::pair<const char*, Type> names[] = {
      {"char", Type::I8},    {"int8", Type::I8},     {"uchar", Type::U8},   {"uint8", Type::U8},
      {"short", Type::I16},  {"int16", Type::I16},   {"ushort", Type::U16}, {"uint16", Type::U16},
      {"int", Type::I32},    {"int32", Type::I32},   {"uint", Type::U32},   {"uint32", Type::U32},
      {"float", Type::F32},  {"float32", Type::F32}, {"double", Type::F64}, {"float64", Type::F64}};
  for (const auto& [n, v] : names)
    if (s == n) {
      t = v;
      return true;
    }
  return false;
}

size_t type_size(Type t) {
  switch (t) {
    case Type::I8: case Type::U8: return 1;
    case Type::I16: case Type::U16: return 2;
    case Type::I32: case Type::U32: case Type::F32: return 4;
    case Type::F64: return 8;
  }
  return 0;
}

struct Property {
  std::string name;
  Type type = Type::F32;
  bool list = false;
  Type count_type = Type::U8;
};

struct Element {
  std::string name;
  size_t count = 0;
  std::vector<Property> props;
};

// Reads values from the body, binary little-endian or whitespace-separated ascii.
class Body {
 public:
  Body(const std::filesystem::path& file, const char* p, const char* end, bool ascii, int line)
      : file_(file), p_(p), end_(end), ascii_(ascii), line_(line) {}

  double read(Type t) {
    if (ascii_) return read_ascii();
    size_t n = type_size(t);
    if (size_t(end_ - p_) < n) fail(file_, ": file ends early inside the ", what_, " data");
    double v = 0;
    switch (t) {
      case Type::I8: { int8_t x; std::memcpy(&x, p_, 1); v = x; break; }
      case Type::U8: { uint8_t x; std::memcpy(&x, p_, 1); v = x; break; }
      case Type::I16: { int16_t x; std::memcpy(&x, p_, 2); v = x; break; }
      case Type::U16: { uint16_t x; std::memcpy(&x, p_, 2); v = x; break; }
      case Type::I32: { int32_t x; std::memcpy(&x, p_, 4); v = x; break; }
      case Type::U32: { uint32_t x; std::memcpy(&x, p_, 4); v = x; break; }
      case Type::F32: { float x; std::memcpy(&x, p_, 4); v = x; break; }
      case Type::F64: { std::memcpy(&v, p_, 8); break; }
    }
    p_ += n;
    return v;
  }
  void set_what(const std::string& w) { what_ = w; }
  // Whether anything but blanks follows the last declared element: a header whose counts fall short of
  // its body (a truncated count, a face line of more values than its length says) dropped the rest unsaid.
  bool more_data() {
    if (!ascii_) return p_ != end_;
    while (p_ < end_ && std::isspace(static_cast<unsigned char>(*p_))) {
      if (*p_ == '\n') ++line_;
      ++p_;
    }
    return p_ != end_;
  }
  std::string where() const { return ascii_ ? cat(file_.string(), ":", line_) : file_.string(); }

 private:
  double read_ascii() {
    while (p_ < end_ && (*p_ == ' ' || *p_ == '\t' || *p_ == '\r' || *p_ == '\n')) {
      if (*p_ == '\n') ++line_;
      ++p_;
    }
    if (p_ == end_) fail(file_, ":", line_, ": file ends early inside the ", what_, " data");
    const char* start = p_;
    while (p_ < end_ && !std::isspace(static_cast<unsigned char>(*p_))) ++p_;
    std::string tok(start, p_);
    char* stop = nullptr;
    double v = std::strtod(tok.c_str(), &stop);
    if (stop != tok.c_str() + tok.size()) fail(file_, ":", line_, ": '", tok, "' is not a number (", what_, ")");
    return v;
  }
  std::filesystem::path file_;
  const char* p_;
  const char* end_;
  bool ascii_;
  int line_;
  std::string what_;
};

}  // namespace

Mesh read_ply(const std::filesystem::path& file) {
  require_file(file, "PLY mesh");  // a FIFO would block the read below forever
  std::ifstream in(file, std::ios::binary);
  if (!in) fail(file, ": cannot open PLY file");
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());

  // Header: text lines up to "end_header".
  size_t pos = 0;
  int line_no = 0;
  auto next_line = [&](std::string& line) {
    if (pos >= data.size()) return false;
    size_t nl = data.find('\n', pos);
    if (nl == std::string::npos) nl = data.size();
    line = data.substr(pos, nl - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    // A last line without its newline ends at the end of the file, not one byte past it: the body
    // read from there was empty, and its bounds checks passed a start beyond the end.
    pos = std::min(nl + 1, data.size());
    ++line_no;
    return true;
  };
  std::string line;
  if (!next_line(line) || line != "ply") fail(file, ": not a PLY file (first line is not 'ply')");
  bool ascii = false, have_format = false;
  std::vector<Element> elements;
  for (;;) {
    if (!next_line(line)) fail(file, ": PLY header has no end_header");
    std::istringstream ls(line);
    std::string kw;
    ls >> kw;
    if (kw == "end_header") break;
    if (kw.empty() || kw == "comment" || kw == "obj_info") continue;
    if (kw == "format") {
      std::string f;
      ls >> f;
      if (f == "ascii") ascii = true;
      else if (f != "binary_little_endian")
        fail(file, ":", line_no, ": PLY format '", f, "' is not supported (ascii or binary_little_endian)");
      have_format = true;
    } else if (kw == "element") {
      Element e;
      long long n = -1;
      ls >> e.name >> n;
      if (!ls || n < 0) fail(file, ":", line_no, ": bad element line '", line, "'");
      e.count = size_t(n);
      // Every element instance takes at least one byte: a count beyond the file size is corrupt.
      if (e.count > data.size()) fail(file, ":", line_no, ": element count ", n, " exceeds the file size");
      elements.push_back(e);
    } else if (kw == "property") {
      if (elements.empty()) fail(file, ":", line_no, ": property before any element");
      Property p;
      std::string t;
      ls >> t;
      if (t == "list") {
        std::string ct, it;
        ls >> ct >> it >> p.name;
        if (!parse_type(ct, p.count_type) || !parse_type(it, p.type))
          fail(file, ":", line_no, ": unknown type in '", line, "'");
        p.list = true;
      } else {
        ls >> p.name;
        if (!parse_type(t, p.type)) fail(file, ":", line_no, ": unknown property type '", t, "'");
      }
      if (p.name.empty()) fail(file, ":", line_no, ": property without a name");
      elements.back().props.push_back(p);
    } else {
      fail(file, ":", line_no, ": unexpected PLY header line '", line, "'");
    }
  }
  if (!have_format) fail(file, ": PLY header has no format line");

  Mesh mesh;
  bool have_colors = false, have_vertices = false;
  Body body(file, data.data() + pos, data.data() + data.size(), ascii, line_no + 1);
  std::vector<double> vals;
  for (const Element& e : elements) {
    body.set_what(e.name);
    const bool is_vertex = e.name == "vertex", is_face = e.name == "face";
    int ix = -1, iy = -1, iz = -1, ir = -1, ig = -1, ib = -1, iface = -1;
    for (int i = 0; i < int(e.props.size()); ++i) {
      const auto& n = e.props[i].name;
      if (n == "x") ix = i;
      if (n == "y") iy = i;
      if (n == "z") iz = i;
      if (n == "red" || n == "diffuse_red") ir = i;
      if (n == "green" || n == "diffuse_green") ig = i;
      if (n == "blue" || n == "diffuse_blue") ib = i;
      if ((n == "vertex_indices" || n == "vertex_index") && e.props[i].list) iface = i;
    }
    if (is_vertex) {
      if (ix < 0 || iy < 0 || iz < 0) fail(file, ": vertex element lacks x, y or z");
      have_vertices = true;
      have_colors = ir >= 0 && ig >= 0 && ib >= 0;
      mesh.vertices.reserve(e.count);
      if (have_colors) mesh.colors.reserve(e.count);
    }
    if (is_face && iface < 0) fail(file, ": face element lacks a vertex_indices list");
    if (is_face) mesh.faces.reserve(e.count);
    vals.resize(e.props.size());
    std::vector<uint32_t> poly;
    for (size_t k = 0; k < e.count; ++k) {
      for (size_t i = 0; i < e.props.size(); ++i) {
        const Property& p = e.props[i];
        if (!p.list) {
          vals[i] = body.read(p.type);
          continue;
        }
        double cnt = body.read(p.count_type);
        // Counts and indices arrive as doubles (a float type is legal PLY): a NaN passes every
        // comparison as false, and a NaN or fractional one made int() undefined or truncated.
        if (!(cnt >= 0 && cnt <= 1e6 && cnt == std::floor(cnt)))
          fail(body.where(), ": bad list length ", cnt, " in ", e.name, " ", k);
        poly.clear();
        for (int j = 0; j < int(cnt); ++j) {
          double idx = body.read(p.type);
          if (is_face && int(i) == iface) {
            if (!(idx >= 0 && idx < double(mesh.vertices.size()) && idx == std::floor(idx)))
              fail(body.where(), ": face ", k, " refers to vertex ", idx, " but there are ",
                   mesh.vertices.size());
            poly.push_back(uint32_t(idx));
          }
        }
      }
      if (is_vertex) {
        // NaN or infinite corners pass every triangle test as false: the face would vanish silently.
        for (int i : {ix, iy, iz})
          if (!(std::abs(vals[i]) <= std::numeric_limits<float>::max()))
            fail(body.where(), ": vertex ", k, " has ", e.props[i].name, " = ", vals[i],
                 ", not a finite float");
        mesh.vertices.emplace_back(float(vals[ix]), float(vals[iy]), float(vals[iz]));
        if (have_colors) {
          auto c8 = [&](int i) {
            double v = vals[i];
            if (!std::isfinite(v))
              fail(body.where(), ": vertex ", k, " has ", e.props[i].name, " = ", v, ", not a finite colour");
            if (e.props[i].type == Type::F32 || e.props[i].type == Type::F64) {
              v *= 255.0;  // 0..1; a float a little beyond (1.0000001) is rounding, kept at the end
            } else if (!(v >= 0 && v <= 255)) {
              // An integer colour outside 0..255 (300, -7) is a damaged file, not a brighter colour.
              fail(body.where(), ": vertex ", k, " has ", e.props[i].name, " = ", v, ", outside the colour range 0 to 255");
            }
            return uint8_t(v < 0 ? 0 : v > 255 ? 255 : v + 0.5);
          };
          mesh.colors.push_back({c8(ir), c8(ig), c8(ib)});
        }
      } else if (is_face) {
        if (poly.size() < 3) fail(body.where(), ": face ", k, " has ", poly.size(), " vertices");
        for (size_t j = 1; j + 1 < poly.size(); ++j) mesh.faces.push_back({poly[0], poly[j], poly[j + 1]});
      }
    }
  }
  if (!have_vertices) fail(file, ": PLY has no vertex element");
  if (body.more_data()) {
    if (ascii)
      fail(body.where(), ": data after the elements the header declares (its counts, or a line's values, fall "
           "short of the body)");
    log::warn(file.string(), ": bytes after the elements the header declares are ignored");
  }

  Material m;
  if (have_colors) {
    m.kind = MaterialKind::VertexColor;
    m.lit = false;
  }
  mesh.materials.push_back(m);
  mesh.compute_bounds();
  return mesh;
}

}  // namespace chungs::synth
