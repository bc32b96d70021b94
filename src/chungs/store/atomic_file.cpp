#include "chungs/store/atomic_file.hpp"

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <thread>

#include "chungs/common/error.hpp"

namespace chungs {

namespace fs = std::filesystem;

namespace {
std::string why() { return std::strerror(errno); }
constexpr const char* kTmpTag = ".tmp-";
std::atomic<uint64_t> tmp_counter{0};
std::atomic<FileEventHook> event_hook{nullptr};
constexpr size_t kSyncThreads = 4;
constexpr size_t kSyncBatch = 256;  // files open at once while flushing

void notify(const fs::path& file, FileEvent e) {
  if (FileEventHook h = event_hook.load()) h(file, e);
}

void write_all(int fd, std::span<const ConstBuffer> parts, const fs::path& file) {
  std::vector<iovec> iov;
  for (const auto& p : parts)
    if (p.size) iov.push_back({const_cast<void*>(p.data), p.size});
  size_t first = 0;
  while (first < iov.size()) {
    const int cnt = int(std::min<size_t>(iov.size() - first, IOV_MAX));
    ssize_t n = ::writev(fd, iov.data() + first, cnt);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail(file.string(), ": write failed: ", why());
    }
    // Skip the buffers written in full, then advance into a partially written one.
    while (first < iov.size() && size_t(n) >= iov[first].iov_len) n -= ssize_t(iov[first++].iov_len);
    if (first < iov.size()) {
      iov[first].iov_base = static_cast<char*>(iov[first].iov_base) + n;
      iov[first].iov_len -= size_t(n);
    }
  }
}
}  // namespace

FileDescriptor::~FileDescriptor() {
  if (fd_ >= 0) ::close(fd_);
}

FileDescriptor& FileDescriptor::operator=(FileDescriptor&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = o.fd_;
    o.fd_ = -1;
  }
  return *this;
}

FileDescriptor open_for_reading(const fs::path& file) {
  notify(file, FileEvent::Reading);
  // Opening a FIFO blocks until a writer comes and a device may never end: a map file that is not a
  // regular file is refused by name. A missing one is left to open(), whose error names it.
  std::error_code ec;
  if (fs::exists(file, ec)) require_file(file);
  int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) fail(file.string(), ": cannot open for reading: ", why());
  return FileDescriptor(fd);
}

uint64_t file_size(const FileDescriptor& fd, const fs::path& file) {
  struct stat st;
  if (::fstat(fd.get(), &st) != 0) fail(file.string(), ": cannot stat: ", why());
  return uint64_t(st.st_size);
}

void read_exact(const FileDescriptor& fd, void* dst, size_t size, const fs::path& file) {
  auto p = static_cast<char*>(dst);
  while (size > 0) {
    ssize_t n = ::read(fd.get(), p, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail(file.string(), ": read failed: ", why());
    }
    if (n == 0) fail(file.string(), ": truncated (", size, " more bytes expected)");
    p += n;
    size -= size_t(n);
  }
}

std::vector<uint8_t> read_whole_file(const fs::path& file) {
  FileDescriptor fd = open_for_reading(file);
  std::vector<uint8_t> out(file_size(fd, file));
  read_exact(fd, out.data(), out.size(), file);
  return out;
}

void sync_directory(const fs::path& dir) {
  const fs::path d = dir.empty() ? fs::path(".") : dir;
  FileDescriptor fd(::open(d.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (!fd) fail(d.string(), ": cannot open folder to flush it: ", why());
  if (::fsync(fd.get()) != 0) fail(d.string(), ": cannot flush folder: ", why());
}

void write_file_atomically(const fs::path& file, std::span<const ConstBuffer> parts, bool durable,
                           bool start_writeback) {
  write_file_atomically(
      file, {nullptr, 0}, [&](const Append& append) {
        for (const ConstBuffer& p : parts) append(p.data, p.size);
      },
      durable, start_writeback);
}

void write_file_atomically(const fs::path& file, ConstBuffer head, const std::function<void(const Append&)>& fill,
                           bool durable, bool start_writeback) {
  // The new file is renamed over the old: over a device, FIFO or folder that replaced it (`export --out
  // /dev/full`, run as root, left a regular file in /dev). Only a regular file, or none, is replaced.
  std::error_code ec;
  if (const fs::file_status st = fs::status(file, ec); fs::exists(st) && !fs::is_regular_file(st))
    fail(file.string(), ": exists and is not a regular file (a folder, FIFO, socket or device); give another path");
  const fs::path tmp =
      file.string() + kTmpTag + std::to_string(::getpid()) + "-" + std::to_string(tmp_counter.fetch_add(1));
  FileDescriptor fd(::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
  if (!fd) fail(tmp.string(), ": cannot create: ", why());
  try {
    if (head.size && ::lseek(fd.get(), off_t(head.size), SEEK_SET) != off_t(head.size))
      fail(tmp.string(), ": cannot seek: ", why());
    fill([&](const void* data, size_t size) {
      const ConstBuffer part{data, size};
      write_all(fd.get(), {&part, 1}, tmp);
    });
    for (size_t done = 0; done < head.size;) {  // filled in by now
      const ssize_t n = ::pwrite(fd.get(), static_cast<const char*>(head.data) + done, head.size - done, off_t(done));
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) fail(tmp.string(), ": write failed: ", why());
      done += size_t(n);
    }
    if (durable && ::fdatasync(fd.get()) != 0) fail(tmp.string(), ": flush failed: ", why());
    // Only a hint, so its failure is not an error.
    if (!durable && start_writeback) ::sync_file_range(fd.get(), 0, 0, SYNC_FILE_RANGE_WRITE);
    if (::close(fd.release()) != 0) fail(tmp.string(), ": close failed: ", why());
    if (::rename(tmp.c_str(), file.c_str()) != 0)
      fail(file.string(), ": cannot rename ", tmp.filename().string(), " over it: ", why());
    if (!durable && start_writeback) notify(file, FileEvent::WritebackStarted);
  } catch (...) {
    fd = FileDescriptor();
    ::unlink(tmp.c_str());
    throw;
  }
  if (durable) sync_directory(file.parent_path());
  notify(file, durable ? FileEvent::Synced : FileEvent::Written);
}

void sync_file(const fs::path& file) {
  FileDescriptor fd(::open(file.c_str(), O_RDONLY | O_CLOEXEC));
  if (!fd) fail(file.string(), ": cannot open to flush it: ", why());
  if (::fdatasync(fd.get()) != 0) fail(file.string(), ": flush failed: ", why());
  notify(file, FileEvent::Synced);
}

namespace {

void sync_batch(std::span<const fs::path> files) {
  std::vector<FileDescriptor> fds;
  fds.reserve(files.size());
  for (const fs::path& f : files) {
    fds.emplace_back(::open(f.c_str(), O_RDONLY | O_CLOEXEC));
    if (!fds.back()) fail(f.string(), ": cannot open to flush it: ", why());
    // Only a hint (fdatasync below is the guarantee), so its failure is not an error.
    ::sync_file_range(fds.back().get(), 0, 0, SYNC_FILE_RANGE_WRITE);
  }
  // Waiting on several files at once lets the filesystem fold their journal commits into one
  // (measured on ext4: 16 files flush in 29 ms with 4 threads, 69 ms one after another).
  std::atomic<size_t> next{0};
  std::vector<int> errors(files.size(), 0);
  auto work = [&] {
    for (size_t i; (i = next++) < fds.size();)
      if (::fdatasync(fds[i].get()) != 0) errors[i] = errno;
  };
  std::vector<std::thread> helpers;
  const size_t threads = std::min<size_t>(kSyncThreads, files.size());
  for (size_t t = 1; t < threads; ++t) helpers.emplace_back(work);
  work();
  for (auto& t : helpers) t.join();
  for (size_t i = 0; i < files.size(); ++i)
    if (errors[i]) fail(files[i].string(), ": flush failed: ", std::strerror(errors[i]));
  for (const fs::path& f : files) notify(f, FileEvent::Synced);
}

}  // namespace

void sync_files(std::span<const fs::path> files) {
  // A batch at a time: every file open at once failed a checkpoint of thousands of chunks with "Too many
  // open files" (1024 descriptors is a common limit), and a batch still folds its journal commits. A
  // quarter of the process's limit at most, the rest being the map's other files and the threads'.
  rlimit limit{};
  const size_t allowed = ::getrlimit(RLIMIT_NOFILE, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY
                             ? std::max<size_t>(size_t(limit.rlim_cur) / 4, 1)
                             : kSyncBatch;
  const size_t batch = std::min(kSyncBatch, allowed);
  for (size_t at = 0; at < files.size(); at += batch) sync_batch(files.subspan(at, std::min(batch, files.size() - at)));
}

void set_file_event_hook(FileEventHook hook) { event_hook.store(hook); }

void remove_file(const fs::path& file, bool durable) {
  notify(file, FileEvent::Removing);
  if (::unlink(file.c_str()) != 0) {
    if (errno == ENOENT) return;
    fail(file.string(), ": cannot remove: ", why());
  }
  if (durable) sync_directory(file.parent_path());
}

bool is_temporary_file(const fs::path& file) {
  return file.filename().string().find(kTmpTag) != std::string::npos;
}

size_t remove_temporary_files(const fs::path& dir) {
  size_t n = 0;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file() && is_temporary_file(e.path()) && fs::remove(e.path(), ec)) ++n;
  if (ec) fail(dir.string(), ": cannot list folder: ", ec.message());
  return n;
}

}  // namespace chungs
