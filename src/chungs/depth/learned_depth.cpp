// LearnedDepth: an ONNX model checked against the contract in learned_depth.hpp, run through the
// runtime that learned_depth_runtime.cpp loads.
#include "chungs/depth/learned_depth.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>

#include "chungs/common/error.hpp"
#include "chungs/common/text_file.hpp"
#include "chungs/depth/learned_depth_runtime.hpp"

namespace chungs {
namespace {

namespace fs = std::filesystem;

std::string shape_text(const std::vector<int64_t>& dims) {
  std::string s = "[";
  for (size_t i = 0; i < dims.size(); ++i) s += (i ? ", " : "") + (dims[i] < 0 ? std::string("?") : cat(dims[i]));
  return s + "]";
}

// A tensor's element type and dimensions (-1: dynamic), from a session's input or output.
struct TensorDecl {
  std::string name;
  int type = 0;
  std::vector<int64_t> dims;
};

std::vector<int64_t> dims_of(const ort::Runtime& rt, const ort::TensorInfo* info, const std::string& what) {
  size_t n = 0;
  rt.check(rt.GetDimensionsCount(info, &n), what);
  std::vector<int64_t> d(n);
  if (n) rt.check(rt.GetDimensions(info, d.data(), n), what);
  return d;
}

// The runtime's strings are freed whatever happens next.
struct OrtString {
  const ort::Runtime& rt;
  char* s = nullptr;
  ~OrtString() { rt.free_string(s); }
};

TensorDecl declared(const ort::Runtime& rt, const ort::Session* session, size_t index, bool input,
                    const std::string& file) {
  TensorDecl t;
  const std::string what = cat(file, ": reading the model's ", input ? "input" : "output", " ", index);
  {
    OrtString name{rt};
    rt.check(input ? rt.SessionGetInputName(session, index, &name.s) : rt.SessionGetOutputName(session, index, &name.s),
             what);
    t.name = name.s ? name.s : "";
  }
  ort::TypeInfo* ti = nullptr;
  rt.check(input ? rt.SessionGetInputTypeInfo(session, index, &ti) : rt.SessionGetOutputTypeInfo(session, index, &ti),
           what);
  try {
    const ort::TensorInfo* tensor = nullptr;
    rt.check(rt.CastTypeInfoToTensorInfo(ti, &tensor), what);
    if (!tensor)
      fail(file, ": the model's ", input ? "input '" : "output '", t.name,
           "' is not a tensor; the contract: learned_depth.hpp / README");
    rt.check(rt.GetTensorElementType(tensor, &t.type), what);
    t.dims = dims_of(rt, tensor, what);
  } catch (...) {
    rt.ReleaseTypeInfo(ti);
    throw;
  }
  rt.ReleaseTypeInfo(ti);
  return t;
}

// "a, b, c" -> three finite numbers, else Error naming the key.
std::array<float, 3> three_numbers(const std::string& text, const std::string& key, const std::string& file,
                                   bool positive) {
  std::array<float, 3> v{};
  std::stringstream ss(text);
  std::string item;
  size_t n = 0;
  while (std::getline(ss, item, ',')) {
    const size_t a = item.find_first_not_of(" \t"), b = item.find_last_not_of(" \t");
    item = a == std::string::npos ? std::string() : item.substr(a, b - a + 1);
    if (n == 3) fail(file, ": metadata ", key, " = '", text, "' has more than three numbers");
    const double x = parse_double(item, cat(file, ": metadata ", key));
    if (positive && !(x > 0)) fail(file, ": metadata ", key, " = '", text, "' must be positive");
    v[n++] = float(x);
  }
  if (n != 3) fail(file, ": metadata ", key, " = '", text, "' must be three numbers separated by commas");
  return v;
}

}  // namespace

struct LearnedDepth::Impl {
  const ort::Runtime* rt = nullptr;
  ort::Session* session = nullptr;
  std::string file;
  TensorDecl input, output;
  int in_w = 0, in_h = 0;  // 0: dynamic (the image's own size)
  std::array<float, 3> mean{0.485f, 0.456f, 0.406f}, std{0.229f, 0.224f, 0.225f};
  bool output_is_depth = false;
  ~Impl() {
    if (session) rt->ReleaseSession(session);
  }
};

LearnedDepth::LearnedDepth(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
LearnedDepth::~LearnedDepth() = default;

std::unique_ptr<LearnedDepth> LearnedDepth::load(const fs::path& model, int threads) {
  const std::string file = model.string();
  // Our own checks first: the runtime's message for a missing file does not say so plainly.
  std::error_code ec;
  if (!fs::exists(model, ec)) fail(file, ": the depth model does not exist");
  if (!fs::is_regular_file(model, ec)) fail(file, ": the depth model is not a file");
  if (fs::file_size(model, ec) == 0 || ec) fail(file, ": the depth model is empty");
  if (!std::ifstream(model)) fail(file, ": the depth model cannot be read");
  if (threads < 0) fail("depth model threads must be 0 (the runtime's default) or more, got ", threads);

  auto impl = std::make_unique<Impl>();
  impl->file = file;
  try {
    impl->rt = &ort::Runtime::get();
  } catch (const Error& e) {
    fail(file, ": ", e.what());
  }
  const ort::Runtime& rt = *impl->rt;
  ort::SessionOptions* options = nullptr;
  rt.check(rt.CreateSessionOptions(&options), file + ": session options");
  try {
    if (threads > 0) rt.check(rt.SetIntraOpNumThreads(options, threads), file + ": threads");
    rt.check(rt.SetInterOpNumThreads(options, 1), file + ": threads");
    rt.check(rt.CreateSession(file.c_str(), options, &impl->session),
             file + ": not an ONNX model that ONNX Runtime " + rt.version() + " can load");
  } catch (...) {
    rt.ReleaseSessionOptions(options);
    throw;
  }
  rt.ReleaseSessionOptions(options);

  size_t n_in = 0, n_out = 0;
  rt.check(rt.SessionGetInputCount(impl->session, &n_in), file + ": inputs");
  rt.check(rt.SessionGetOutputCount(impl->session, &n_out), file + ": outputs");
  const std::string contract = "the contract: one float input [1, 3, H, W], one float output [1, 1, H, W] or [1, H, W]";
  if (n_in != 1) fail(file, ": the model has ", n_in, " inputs; ", contract);
  if (n_out != 1) fail(file, ": the model has ", n_out, " outputs; ", contract);
  impl->input = declared(rt, impl->session, 0, true, file);
  impl->output = declared(rt, impl->session, 0, false, file);
  const auto& in = impl->input.dims;
  const auto& out = impl->output.dims;
  if (impl->input.type != ort::kElementFloat)
    fail(file, ": input '", impl->input.name, "' has element type ", impl->input.type, ", not float32; ", contract);
  if (impl->output.type != ort::kElementFloat)
    fail(file, ": output '", impl->output.name, "' has element type ", impl->output.type, ", not float32; ", contract);
  auto one = [](int64_t d) { return d == 1 || d < 0; };
  if (in.size() != 4 || !one(in[0]) || !(in[1] == 3 || in[1] < 0) || in[2] == 0 || in[3] == 0)
    fail(file, ": input '", impl->input.name, "' has shape ", shape_text(in), "; ", contract);
  const bool out_ok = (out.size() == 4 && one(out[0]) && one(out[1])) || (out.size() == 3 && one(out[0]));
  if (!out_ok || out[out.size() - 1] == 0 || out[out.size() - 2] == 0)
    fail(file, ": output '", impl->output.name, "' has shape ", shape_text(out), "; ", contract);
  impl->in_h = in[2] > 0 ? int(in[2]) : 0;
  impl->in_w = in[3] > 0 ? int(in[3]) : 0;
  if ((impl->in_h > 0) != (impl->in_w > 0))
    fail(file, ": input '", impl->input.name, "' has shape ", shape_text(in),
         "; its height and width must both be fixed or both dynamic");

  ort::ModelMetadata* meta = nullptr;
  rt.check(rt.SessionGetModelMetadata(impl->session, &meta), file + ": metadata");
  try {
    auto lookup = [&](const char* key) -> std::optional<std::string> {
      OrtString v{rt};
      rt.check(rt.ModelMetadataLookupCustomMetadataMap(meta, key, &v.s), file + ": metadata " + key);
      if (!v.s) return std::nullopt;
      return std::string(v.s);
    };
    if (auto m = lookup("chungs.mean")) impl->mean = three_numbers(*m, "chungs.mean", file, false);
    if (auto s = lookup("chungs.std")) impl->std = three_numbers(*s, "chungs.std", file, true);
    if (auto o = lookup("chungs.output")) {
      if (*o == "depth")
        impl->output_is_depth = true;
      else if (*o != "inverse_depth")
        fail(file, ": metadata chungs.output = '", *o, "' must be inverse_depth or depth");
    }
  } catch (...) {
    rt.ReleaseModelMetadata(meta);
    throw;
  }
  rt.ReleaseModelMetadata(meta);
  return std::unique_ptr<LearnedDepth>(new LearnedDepth(std::move(impl)));
}

ImageF LearnedDepth::predict(const Image8& image) const {
  const Impl& m = *impl_;
  const ort::Runtime& rt = *m.rt;
  if (image.empty() || !(image.channels() == 1 || image.channels() == 3 || image.channels() == 4))
    fail(m.file, ": predict needs a gray, RGB or RGBA image, got ", image.width(), "x", image.height(), "x",
         image.channels());
  const int w = m.in_w ? m.in_w : image.width(), h = m.in_h ? m.in_h : image.height();
  ImageF rgb = to_float(image);  // [0, 1]
  if (rgb.channels() == 4) {
    ImageF three(rgb.width(), rgb.height(), 3);
    for (size_t i = 0; i < rgb.pixels(); ++i)
      for (int c = 0; c < 3; ++c) three.data()[i * 3 + c] = rgb.data()[i * 4 + c];
    rgb = std::move(three);
  }
  rgb = to_rgb(rgb);
  if (w != rgb.width() || h != rgb.height()) rgb = resize_bilinear(rgb, w, h);
  // Planar [1, 3, h, w], normalised per channel.
  std::vector<float> planes(size_t(3) * w * h);
  for (int c = 0; c < 3; ++c) {
    float* plane = planes.data() + size_t(c) * w * h;
    for (size_t i = 0; i < size_t(w) * h; ++i) plane[i] = (rgb.data()[i * 3 + c] - m.mean[c]) / m.std[c];
  }
  const int64_t shape[4] = {1, 3, h, w};
  ort::Value* in = nullptr;
  ort::Value* out = nullptr;
  const std::string what = m.file + ": running the depth model";
  rt.check(rt.CreateTensorWithDataAsOrtValue(rt.cpu_memory(), planes.data(), planes.size() * sizeof(float), shape, 4,
                                             ort::kElementFloat, &in),
           what);
  ImageF pred;
  try {
    const char* in_name = m.input.name.c_str();
    const char* out_name = m.output.name.c_str();
    rt.check(rt.Run(m.session, &in_name, &in, 1, &out_name, 1, &out), what);
    ort::TensorInfo* info = nullptr;
    rt.check(rt.GetTensorTypeAndShape(out, &info), what);
    std::vector<int64_t> dims;
    try {
      dims = dims_of(rt, info, what);
    } catch (...) {
      rt.ReleaseTensorInfo(info);
      throw;
    }
    rt.ReleaseTensorInfo(info);
    // The declared shape allowed dynamic sizes: the produced one must still be one map.
    const bool ok = (dims.size() == 4 && dims[0] == 1 && dims[1] == 1) || (dims.size() == 3 && dims[0] == 1);
    if (!ok || dims[dims.size() - 1] < 1 || dims[dims.size() - 2] < 1)
      fail(m.file, ": output '", m.output.name, "' came out with shape ", shape_text(dims), " for a ", w, "x", h,
           " input; the contract: [1, 1, H, W] or [1, H, W]");
    const int ow = int(dims[dims.size() - 1]), oh = int(dims[dims.size() - 2]);
    void* data = nullptr;
    rt.check(rt.GetTensorMutableData(out, &data), what);
    pred = ImageF(ow, oh, 1);
    std::memcpy(pred.data(), data, pred.size() * sizeof(float));
  } catch (...) {
    rt.ReleaseValue(in);
    if (out) rt.ReleaseValue(out);
    throw;
  }
  rt.ReleaseValue(in);
  rt.ReleaseValue(out);
  if (m.output_is_depth)
    for (float& v : pred.vec()) v = v > 0 && std::isfinite(v) ? 1.f / v : std::nanf("");
  if (pred.width() != image.width() || pred.height() != image.height())
    pred = resize_bilinear(pred, image.width(), image.height());
  return pred;
}

std::string LearnedDepth::describe() const {
  const Impl& m = *impl_;
  auto three = [](const std::array<float, 3>& v) { return cat(v[0], ", ", v[1], ", ", v[2]); };
  return cat(m.file, ": input '", m.input.name, "' ", shape_text(m.input.dims),
             m.in_w ? cat(" (images resized to ", m.in_w, "x", m.in_h, ")") : std::string(" (images at their size)"),
             ", output '", m.output.name, "' ", shape_text(m.output.dims),
             m.output_is_depth ? " depth" : " inverse depth", ", mean (", three(m.mean), "), std (", three(m.std),
             "); ONNX Runtime ", m.rt->version(), " (", m.rt->library(), ")");
}

DepthRuntimeProbe probe_depth_runtime() {
  DepthRuntimeProbe p;
  if (const ort::Runtime* rt = ort::Runtime::find(&p.reason)) {
    p.available = true;
    p.library = rt->library();
    p.version = rt->version();
    p.reason.clear();
  }
  return p;
}

}  // namespace chungs
