// Crash-safe file replacement and small POSIX helpers. A writer puts the new content in a
// temporary file beside the target, flushes it, renames it over the target and flushes the folder,
// so after a crash (even SIGKILL or power loss when `durable`) the target holds the old or the
// new content in full, never a mix. Leftover temporaries are recognised and removed on open.
#pragma once
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <vector>

namespace chungs {

struct ConstBuffer {
  const void* data;
  size_t size;
};

// An open file descriptor, closed on destruction.
class FileDescriptor {
 public:
  FileDescriptor() = default;
  explicit FileDescriptor(int fd) : fd_(fd) {}
  ~FileDescriptor();
  FileDescriptor(FileDescriptor&& o) noexcept : fd_(o.fd_) { o.fd_ = -1; }
  FileDescriptor& operator=(FileDescriptor&& o) noexcept;
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  int get() const { return fd_; }
  int release() {
    int fd = fd_;
    fd_ = -1;
    return fd;
  }
  explicit operator bool() const { return fd_ >= 0; }

 private:
  int fd_ = -1;
};

FileDescriptor open_for_reading(const std::filesystem::path& file);
uint64_t file_size(const FileDescriptor& fd, const std::filesystem::path& file);
// Reads exactly `size` bytes or throws naming the file ("truncated" on early end of file).
void read_exact(const FileDescriptor& fd, void* dst, size_t size, const std::filesystem::path& file);
std::vector<uint8_t> read_whole_file(const std::filesystem::path& file);

// Writes the concatenation of `parts` to `file` crash-safely (see above). With durable = false the
// flushes are skipped: still atomic against a killed process, not against power loss.
// start_writeback (without durable): ask the kernel to begin writing the data to disk now,
// without waiting, so that a later flush (sync_files) finds little left to do.
void write_file_atomically(const std::filesystem::path& file, std::span<const ConstBuffer> parts,
                           bool durable, bool start_writeback = false);
// The same for content made while it is written, so that it need not be held whole: fill(append)
// gives it in order, append(data, size) writing each piece before it returns (its buffer may be
// reused); `head` is written at the start once fill has returned, over `head.size` bytes left for it
// (a header that sums up what follows).
using Append = std::function<void(const void* data, size_t size)>;
void write_file_atomically(const std::filesystem::path& file, ConstBuffer head,
                           const std::function<void(const Append&)>& fill, bool durable,
                           bool start_writeback = false);
// Flushes a file's data (fdatasync) so that it survives power loss; its folder entry needs
// sync_directory as well.
void sync_file(const std::filesystem::path& file);
// sync_file for many files at once: starts the writeback of all of them before waiting on any, so
// the disk sees one batch instead of one round trip per file.
void sync_files(std::span<const std::filesystem::path> files);
// Removes `file` if present, then flushes its folder when durable.
void remove_file(const std::filesystem::path& file, bool durable);
void sync_directory(const std::filesystem::path& dir);

// Test hook, told of every file made visible without a flush (Written), of every file flushed
// (Synced), so a test can model power loss by discarding what was never flushed, of every file
// about to be removed (Removing), so a test can hold a removal where it happens, of every file
// opened for reading (Reading), so a test can hold a read, and of every file whose writeback was
// started without waiting for it (WritebackStarted; still not flushed).
enum class FileEvent { Written, Synced, Removing, Reading, WritebackStarted };
using FileEventHook = void (*)(const std::filesystem::path& file, FileEvent event);
void set_file_event_hook(FileEventHook hook);  // nullptr turns it off

// Temporaries are named "<target>.tmp-<pid>-<counter>".
bool is_temporary_file(const std::filesystem::path& file);
// Deletes temporaries left in `dir` by a crashed writer; returns how many.
size_t remove_temporary_files(const std::filesystem::path& dir);

}  // namespace chungs
