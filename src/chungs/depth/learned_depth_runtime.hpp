// ONNX Runtime loaded at run time (dlopen): the project builds and runs without it, and only
// --mono-depth-model needs it. Its C API is one exported function, OrtGetApiBase, which hands out a
// table of function pointers whose order is fixed for every release (entries are only appended).
//
// The runtime's own header is not installed by the packages this project may use (the npm package
// onnxruntime-node ships the library without it, Debian 12 has no ONNX Runtime), so this file
// declares the few entries learned_depth.cpp calls, by their documented positions in the table and
// with their documented signatures (our declarations, not a copy of the header).
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>

namespace chungs::ort {

// Opaque handles of the C API.
struct Status;
struct Env;
struct Session;
struct SessionOptions;
struct Value;
struct MemoryInfo;
struct TypeInfo;
struct TensorInfo;  // OrtTensorTypeAndShapeInfo
struct Allocator;
struct ModelMetadata;

// The values of the C API's enums that are passed here.
constexpr int kLoggingError = 3;        // OrtLoggingLevel ORT_LOGGING_LEVEL_ERROR
constexpr int kElementFloat = 1;        // ONNXTensorElementDataType FLOAT
constexpr int kArenaAllocator = 1;      // OrtAllocatorType OrtArenaAllocator
constexpr int kMemTypeDefault = 0;      // OrtMemType OrtMemTypeDefault
// The table version asked for: every entry below exists from it on (ONNX Runtime 1.8, 2021).
constexpr uint32_t kApiVersion = 8;

// The loaded runtime with typed entries of its table. Process-wide and never unloaded (the runtime's
// thread pools outlive any one session); every call here is thread-safe in the runtime.
class Runtime {
 public:
  // The runtime as the search finds it now (learned_depth.hpp says the order); throws Error saying
  // what to install when none loads.
  static const Runtime& get();
  // The same search without throwing: nullptr and the reason.
  static const Runtime* find(std::string* reason);

  const std::string& library() const { return library_; }
  const std::string& version() const { return version_; }
  Env* env() const { return env_; }
  Allocator* allocator() const { return allocator_; }
  const MemoryInfo* cpu_memory() const { return cpu_memory_; }

  // Throws Error "<what>: <the runtime's message>" when status is an error (and releases it).
  void check(Status* status, const std::string& what) const;

  // Entries, named as in the C API.
  Status* CreateSessionOptions(SessionOptions** out) const;
  Status* SetIntraOpNumThreads(SessionOptions* options, int threads) const;
  Status* SetInterOpNumThreads(SessionOptions* options, int threads) const;
  Status* CreateSession(const char* model_path, const SessionOptions* options, Session** out) const;
  Status* SessionGetInputCount(const Session* session, size_t* out) const;
  Status* SessionGetOutputCount(const Session* session, size_t* out) const;
  Status* SessionGetInputTypeInfo(const Session* session, size_t index, TypeInfo** out) const;
  Status* SessionGetOutputTypeInfo(const Session* session, size_t index, TypeInfo** out) const;
  Status* SessionGetInputName(const Session* session, size_t index, char** out) const;   // free with free_string
  Status* SessionGetOutputName(const Session* session, size_t index, char** out) const;  // free with free_string
  Status* CastTypeInfoToTensorInfo(const TypeInfo* info, const TensorInfo** out) const;  // not owned: no release
  Status* GetTensorElementType(const TensorInfo* info, int* out) const;
  Status* GetDimensionsCount(const TensorInfo* info, size_t* out) const;
  Status* GetDimensions(const TensorInfo* info, int64_t* out, size_t count) const;
  Status* CreateTensorWithDataAsOrtValue(const MemoryInfo* memory, void* data, size_t bytes, const int64_t* shape,
                                         size_t rank, int element_type, Value** out) const;
  Status* Run(Session* session, const char* const* input_names, const Value* const* inputs, size_t input_count,
              const char* const* output_names, size_t output_count, Value** outputs) const;
  Status* GetTensorTypeAndShape(const Value* value, TensorInfo** out) const;  // release: ReleaseTensorInfo
  Status* GetTensorMutableData(Value* value, void** out) const;
  Status* SessionGetModelMetadata(const Session* session, ModelMetadata** out) const;
  // *out is nullptr when the key is absent; else free with free_string.
  Status* ModelMetadataLookupCustomMetadataMap(const ModelMetadata* metadata, const char* key, char** out) const;
  void free_string(char* s) const;

  void ReleaseSession(Session* p) const;
  void ReleaseSessionOptions(SessionOptions* p) const;
  void ReleaseValue(Value* p) const;
  void ReleaseTypeInfo(TypeInfo* p) const;
  void ReleaseTensorInfo(TensorInfo* p) const;
  void ReleaseModelMetadata(ModelMetadata* p) const;

 private:
  using Entry = void (*)();
  template <typename Fn>
  Fn entry(size_t index) const {
    return reinterpret_cast<Fn>(table_[index]);
  }
  static const Runtime* load(const std::string& library, std::string* reason);

  std::string library_, version_;
  const Entry* table_ = nullptr;
  Env* env_ = nullptr;
  Allocator* allocator_ = nullptr;
  MemoryInfo* cpu_memory_ = nullptr;
};

}  // namespace chungs::ort
