#include "chungs/depth/learned_depth_runtime.hpp"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "chungs/common/error.hpp"

namespace chungs::ort {
namespace {

// Positions in the function table (OrtApi), as documented for the C API; the table only grows, so
// these hold for every release from kApiVersion on.
enum Slot : size_t {
  kGetErrorMessage = 2,
  kCreateEnv = 3,
  kCreateSession = 7,
  kRun = 9,
  kCreateSessionOptions = 10,
  kSetIntraOpNumThreads = 24,
  kSetInterOpNumThreads = 25,
  kSessionGetInputCount = 30,
  kSessionGetOutputCount = 31,
  kSessionGetInputTypeInfo = 33,
  kSessionGetOutputTypeInfo = 34,
  kSessionGetInputName = 36,
  kSessionGetOutputName = 37,
  kCreateTensorWithDataAsOrtValue = 49,
  kGetTensorMutableData = 51,
  kCastTypeInfoToTensorInfo = 55,
  kGetTensorElementType = 60,
  kGetDimensionsCount = 61,
  kGetDimensions = 62,
  kGetTensorTypeAndShape = 65,
  kCreateCpuMemoryInfo = 69,
  kAllocatorFree = 76,
  kGetAllocatorWithDefaultOptions = 78,
  kReleaseStatus = 93,
  kReleaseSession = 95,
  kReleaseValue = 96,
  kReleaseTypeInfo = 98,
  kReleaseTensorTypeAndShapeInfo = 99,
  kReleaseSessionOptions = 100,
  kSessionGetModelMetadata = 111,
  kModelMetadataLookupCustomMetadataMap = 116,
  kReleaseModelMetadata = 118,
};

// OrtApiBase: what OrtGetApiBase returns.
struct ApiBase {
  const void* (*get_api)(uint32_t version);
  const char* (*get_version_string)();
};

#ifndef CHUNGS_ONNXRUNTIME_NPM_VERSION
#define CHUNGS_ONNXRUNTIME_NPM_VERSION "1.x"
#endif

std::string install_hint() {
  std::string build_copy;
#ifdef CHUNGS_ONNXRUNTIME_BUILD_LIB
  build_copy = cat(" (the build installs it as ", CHUNGS_ONNXRUNTIME_BUILD_LIB, " when npm is found)");
#endif
  return cat("install ONNX Runtime's library: scripts/setup.sh builds with it from the npm package onnxruntime-node",
             build_copy, "; or run `npm install --ignore-scripts onnxruntime-node@", CHUNGS_ONNXRUNTIME_NPM_VERSION,
             "` in a folder DIR and set CHUNGS_ONNXRUNTIME=DIR/node_modules/onnxruntime-node/bin/napi-v6/linux/x64/"
             "libonnxruntime.so.1; or install a system libonnxruntime.so.1");
}

std::mutex g_mutex;
std::map<std::string, std::unique_ptr<Runtime>>& loaded() {
  static std::map<std::string, std::unique_ptr<Runtime>> m;
  return m;
}

}  // namespace

const Runtime* Runtime::load(const std::string& library, std::string* reason) {
  // RTLD_LOCAL: the runtime's own symbols (protobuf, ...) stay out of the process's namespace.
  void* handle = dlopen(library.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* e = dlerror();
    *reason = e ? e : "cannot be loaded";
    return nullptr;
  }
  using GetApiBase = const ApiBase* (*)();
  auto get_base = reinterpret_cast<GetApiBase>(dlsym(handle, "OrtGetApiBase"));
  const ApiBase* base = get_base ? get_base() : nullptr;
  if (!base) {
    *reason = "has no OrtGetApiBase: not ONNX Runtime";
    return nullptr;  // a library that is not ONNX Runtime stays loaded: unloading foreign code is unsafe
  }
  auto rt = std::make_unique<Runtime>();
  rt->library_ = library;
  rt->version_ = base->get_version_string ? base->get_version_string() : "?";
  rt->table_ = static_cast<const Entry*>(base->get_api(kApiVersion));
  if (!rt->table_) {
    *reason = cat("is ONNX Runtime ", rt->version_, ", older than this build needs (C API version ", kApiVersion,
                  ", ONNX Runtime 1.8)");
    return nullptr;
  }
  using CreateEnv = Status* (*)(int, const char*, Env**);
  using CreateCpuMemoryInfo = Status* (*)(int, int, MemoryInfo**);
  using GetAllocator = Status* (*)(Allocator**);
  try {
    rt->check(rt->entry<CreateEnv>(kCreateEnv)(kLoggingError, "diskchungs", &rt->env_), "creating its environment");
    rt->check(rt->entry<CreateCpuMemoryInfo>(kCreateCpuMemoryInfo)(kArenaAllocator, kMemTypeDefault, &rt->cpu_memory_),
              "describing CPU memory");
    rt->check(rt->entry<GetAllocator>(kGetAllocatorWithDefaultOptions)(&rt->allocator_), "getting its allocator");
  } catch (const Error& e) {
    *reason = e.what();
    return nullptr;
  }
  auto& m = loaded();
  return m.emplace(library, std::move(rt)).first->second.get();
}

const Runtime* Runtime::find(std::string* reason) {
  std::lock_guard<std::mutex> lock(g_mutex);
  std::vector<std::string> candidates;
  const char* env = std::getenv("CHUNGS_ONNXRUNTIME");
  const bool named = env && *env;
  if (named) {
    candidates.push_back(env);
  } else {
#ifdef CHUNGS_ONNXRUNTIME_BUILD_LIB
    if (std::filesystem::exists(CHUNGS_ONNXRUNTIME_BUILD_LIB)) candidates.push_back(CHUNGS_ONNXRUNTIME_BUILD_LIB);
#endif
    candidates.push_back("libonnxruntime.so.1");
    candidates.push_back("libonnxruntime.so");
  }
  std::string tried;
  for (const auto& c : candidates) {
    if (auto it = loaded().find(c); it != loaded().end()) return it->second.get();
    std::string why;
    if (const Runtime* rt = load(c, &why)) return rt;
    tried += cat(tried.empty() ? "" : "; ", c, ": ", why);
  }
  if (reason)
    *reason = named ? cat("ONNX Runtime named by CHUNGS_ONNXRUNTIME cannot be used (", tried, "); ", install_hint())
                    : cat("ONNX Runtime is not installed (", tried, "); ", install_hint());
  return nullptr;
}

const Runtime& Runtime::get() {
  std::string reason;
  const Runtime* rt = find(&reason);
  if (!rt) fail(reason);
  return *rt;
}

void Runtime::check(Status* status, const std::string& what) const {
  if (!status) return;
  using GetErrorMessage = const char* (*)(const Status*);
  using ReleaseStatus = void (*)(Status*);
  const char* m = entry<GetErrorMessage>(kGetErrorMessage)(status);
  std::string msg = m ? m : "unknown error";
  entry<ReleaseStatus>(kReleaseStatus)(status);
  // The runtime's messages may span lines; the CLI prints one.
  for (char& c : msg)
    if (c == '\n' || c == '\r') c = ' ';
  fail(what, ": ", msg);
}

Status* Runtime::CreateSessionOptions(SessionOptions** out) const {
  return entry<Status* (*)(SessionOptions**)>(kCreateSessionOptions)(out);
}
Status* Runtime::SetIntraOpNumThreads(SessionOptions* o, int n) const {
  return entry<Status* (*)(SessionOptions*, int)>(kSetIntraOpNumThreads)(o, n);
}
Status* Runtime::SetInterOpNumThreads(SessionOptions* o, int n) const {
  return entry<Status* (*)(SessionOptions*, int)>(kSetInterOpNumThreads)(o, n);
}
Status* Runtime::CreateSession(const char* path, const SessionOptions* o, Session** out) const {
  return entry<Status* (*)(const Env*, const char*, const SessionOptions*, Session**)>(kCreateSession)(env_, path, o,
                                                                                                      out);
}
Status* Runtime::SessionGetInputCount(const Session* s, size_t* out) const {
  return entry<Status* (*)(const Session*, size_t*)>(kSessionGetInputCount)(s, out);
}
Status* Runtime::SessionGetOutputCount(const Session* s, size_t* out) const {
  return entry<Status* (*)(const Session*, size_t*)>(kSessionGetOutputCount)(s, out);
}
Status* Runtime::SessionGetInputTypeInfo(const Session* s, size_t i, TypeInfo** out) const {
  return entry<Status* (*)(const Session*, size_t, TypeInfo**)>(kSessionGetInputTypeInfo)(s, i, out);
}
Status* Runtime::SessionGetOutputTypeInfo(const Session* s, size_t i, TypeInfo** out) const {
  return entry<Status* (*)(const Session*, size_t, TypeInfo**)>(kSessionGetOutputTypeInfo)(s, i, out);
}
Status* Runtime::SessionGetInputName(const Session* s, size_t i, char** out) const {
  return entry<Status* (*)(const Session*, size_t, Allocator*, char**)>(kSessionGetInputName)(s, i, allocator_, out);
}
Status* Runtime::SessionGetOutputName(const Session* s, size_t i, char** out) const {
  return entry<Status* (*)(const Session*, size_t, Allocator*, char**)>(kSessionGetOutputName)(s, i, allocator_, out);
}
Status* Runtime::CastTypeInfoToTensorInfo(const TypeInfo* t, const TensorInfo** out) const {
  return entry<Status* (*)(const TypeInfo*, const TensorInfo**)>(kCastTypeInfoToTensorInfo)(t, out);
}
Status* Runtime::GetTensorElementType(const TensorInfo* t, int* out) const {
  return entry<Status* (*)(const TensorInfo*, int*)>(kGetTensorElementType)(t, out);
}
Status* Runtime::GetDimensionsCount(const TensorInfo* t, size_t* out) const {
  return entry<Status* (*)(const TensorInfo*, size_t*)>(kGetDimensionsCount)(t, out);
}
Status* Runtime::GetDimensions(const TensorInfo* t, int64_t* out, size_t n) const {
  return entry<Status* (*)(const TensorInfo*, int64_t*, size_t)>(kGetDimensions)(t, out, n);
}
Status* Runtime::CreateTensorWithDataAsOrtValue(const MemoryInfo* m, void* data, size_t bytes, const int64_t* shape,
                                                size_t rank, int type, Value** out) const {
  return entry<Status* (*)(const MemoryInfo*, void*, size_t, const int64_t*, size_t, int, Value**)>(
      kCreateTensorWithDataAsOrtValue)(m, data, bytes, shape, rank, type, out);
}
Status* Runtime::Run(Session* s, const char* const* in_names, const Value* const* in, size_t n_in,
                     const char* const* out_names, size_t n_out, Value** out) const {
  return entry<Status* (*)(Session*, const void*, const char* const*, const Value* const*, size_t, const char* const*,
                           size_t, Value**)>(kRun)(s, nullptr, in_names, in, n_in, out_names, n_out, out);
}
Status* Runtime::GetTensorTypeAndShape(const Value* v, TensorInfo** out) const {
  return entry<Status* (*)(const Value*, TensorInfo**)>(kGetTensorTypeAndShape)(v, out);
}
Status* Runtime::GetTensorMutableData(Value* v, void** out) const {
  return entry<Status* (*)(Value*, void**)>(kGetTensorMutableData)(v, out);
}
Status* Runtime::SessionGetModelMetadata(const Session* s, ModelMetadata** out) const {
  return entry<Status* (*)(const Session*, ModelMetadata**)>(kSessionGetModelMetadata)(s, out);
}
Status* Runtime::ModelMetadataLookupCustomMetadataMap(const ModelMetadata* m, const char* key, char** out) const {
  return entry<Status* (*)(const ModelMetadata*, Allocator*, const char*, char**)>(
      kModelMetadataLookupCustomMetadataMap)(m, allocator_, key, out);
}
void Runtime::free_string(char* s) const {
  if (!s) return;
  // AllocatorFree returns a status that cannot be an error for a pointer the allocator gave out.
  Status* st = entry<Status* (*)(Allocator*, void*)>(kAllocatorFree)(allocator_, s);
  if (st) entry<void (*)(Status*)>(kReleaseStatus)(st);
}
void Runtime::ReleaseSession(Session* p) const { entry<void (*)(Session*)>(kReleaseSession)(p); }
void Runtime::ReleaseSessionOptions(SessionOptions* p) const {
  entry<void (*)(SessionOptions*)>(kReleaseSessionOptions)(p);
}
void Runtime::ReleaseValue(Value* p) const { entry<void (*)(Value*)>(kReleaseValue)(p); }
void Runtime::ReleaseTypeInfo(TypeInfo* p) const { entry<void (*)(TypeInfo*)>(kReleaseTypeInfo)(p); }
void Runtime::ReleaseTensorInfo(TensorInfo* p) const {
  entry<void (*)(TensorInfo*)>(kReleaseTensorTypeAndShapeInfo)(p);
}
void Runtime::ReleaseModelMetadata(ModelMetadata* p) const {
  entry<void (*)(ModelMetadata*)>(kReleaseModelMetadata)(p);
}

}  // namespace chungs::ort
