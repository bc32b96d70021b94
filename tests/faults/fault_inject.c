// LD_PRELOAD interposer that makes one chosen file operation inside a map folder fail, so a test
// can check what a run leaves behind when the disk refuses a write at any point (issue 21).
//
// Environment:
//   FAULT_DIR     absolute map folder; only paths inside it (and descriptors opened there) count
//   FAULT_AT      1-based index of the counted mutating operation to fail (0 or unset: none)
//   FAULT_ERRNO   EIO (default) or ENOSPC
//   FAULT_READ_AT 1-based index of the read on a descriptor opened for a path containing
//                 FAULT_READ_MATCH (default "/chunks/") to fail with EIO
//   FAULT_LOG     file that gets one line per counted operation: "<index> <kind> <path>[ FAILED]"
//   FAULT_KEEP    folder that gets a copy of the map folder's manifest.txt, keyframes.txt and
//                 run_state.json after each rename that puts one in place (<seq>-<name>), so a
//                 reference run shows what each commit held
// Counted: opens that may write or create, write/pwrite/writev/fwrite, fsync/fdatasync (of files
// and folders), rename, mkdir, unlink/remove/rmdir. Reads and read-only opens are not counted,
// but descriptors opened inside the folder are tracked so that a later fsync or write counts.
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/uio.h>
#include <unistd.h>

enum { kMaxFds = 65536 };
// 0: not tracked; 1: inside the folder; 2: inside the folder and matching FAULT_READ_MATCH;
// bit 4: a folder (its fsync is logged as such).
static _Atomic unsigned char tracked[kMaxFds];
static atomic_long op_count, read_count;
static long fail_at, read_fail_at;
static int fail_errno = EIO;
static char dir[PATH_MAX];
static size_t dir_len;
static char read_match[256] = "/chunks/";
static int log_fd = -1;
static char keep_dir[PATH_MAX];
static atomic_long keep_seq;
static pthread_once_t once = PTHREAD_ONCE_INIT;
static pthread_mutex_t log_mutex = PTHREAD_MUTEX_INITIALIZER;

#define REAL(name) static __typeof__(name)* real_##name
REAL(open);
REAL(open64);
REAL(openat);
REAL(openat64);
REAL(creat);
REAL(fopen);
REAL(fopen64);
REAL(fclose);
REAL(close);
REAL(write);
REAL(pwrite);
REAL(pwrite64);
REAL(writev);
REAL(pwritev);
REAL(fwrite);
REAL(fsync);
REAL(fdatasync);
REAL(rename);
REAL(renameat);
REAL(renameat2);
REAL(mkdir);
REAL(mkdirat);
REAL(unlink);
REAL(unlinkat);
REAL(rmdir);
REAL(remove);
REAL(read);
REAL(pread);
REAL(pread64);

static void init(void) {
#define BIND(name) real_##name = (__typeof__(name)*)dlsym(RTLD_NEXT, #name)
  BIND(open);
  BIND(open64);
  BIND(openat);
  BIND(openat64);
  BIND(creat);
  BIND(fopen);
  BIND(fopen64);
  BIND(fclose);
  BIND(close);
  BIND(write);
  BIND(pwrite);
  BIND(pwrite64);
  BIND(writev);
  BIND(pwritev);
  BIND(fwrite);
  BIND(fsync);
  BIND(fdatasync);
  BIND(rename);
  BIND(renameat);
  BIND(renameat2);
  BIND(mkdir);
  BIND(mkdirat);
  BIND(unlink);
  BIND(unlinkat);
  BIND(rmdir);
  BIND(remove);
  BIND(read);
  BIND(pread);
  BIND(pread64);
  const char* d = getenv("FAULT_DIR");
  if (d && d[0] == '/') {
    snprintf(dir, sizeof dir, "%s", d);
    dir_len = strlen(dir);
    while (dir_len > 1 && dir[dir_len - 1] == '/') dir[--dir_len] = '\0';
  }
  const char* at = getenv("FAULT_AT");
  fail_at = at ? atol(at) : 0;
  const char* rat = getenv("FAULT_READ_AT");
  read_fail_at = rat ? atol(rat) : 0;
  const char* m = getenv("FAULT_READ_MATCH");
  if (m) snprintf(read_match, sizeof read_match, "%s", m);
  const char* e = getenv("FAULT_ERRNO");
  if (e && strcmp(e, "ENOSPC") == 0) fail_errno = ENOSPC;
  const char* k = getenv("FAULT_KEEP");
  if (k) snprintf(keep_dir, sizeof keep_dir, "%s", k);
  const char* l = getenv("FAULT_LOG");
  if (l) log_fd = real_open(l, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
}

static void ensure_init(void) { pthread_once(&once, init); }

// The absolute form of `path` (relative to `dirfd` or the working folder); no symlinks resolved,
// which the callers under test never use inside the map folder.
static void absolute(int dirfd, const char* path, char* out, size_t n) {
  if (path[0] == '/') {
    snprintf(out, n, "%s", path);
    return;
  }
  char base[PATH_MAX] = "";
  if (dirfd == AT_FDCWD) {
    if (!getcwd(base, sizeof base)) base[0] = '\0';
  } else {
    char link[64];
    snprintf(link, sizeof link, "/proc/self/fd/%d", dirfd);
    ssize_t len = readlink(link, base, sizeof base - 1);
    base[len > 0 ? len : 0] = '\0';
  }
  snprintf(out, n, "%s/%s", base, path);
}

static int inside(int dirfd, const char* path, char* abs, size_t n) {
  ensure_init();
  if (!dir_len || !path) return 0;
  absolute(dirfd, path, abs, n);
  return strncmp(abs, dir, dir_len) == 0 && (abs[dir_len] == '/' || abs[dir_len] == '\0');
}

static int fd_inside(int fd) {
  ensure_init();
  return fd >= 0 && fd < kMaxFds && tracked[fd] != 0;
}

static const char* fd_path(int fd, char* buf, size_t n) {
  char link[64];
  snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
  ssize_t len = readlink(link, buf, n - 1);
  buf[len > 0 ? len : 0] = '\0';
  return buf;
}

static void log_line(long index, const char* kind, const char* path, int failed) {
  if (log_fd < 0) return;
  char line[PATH_MAX + 64];
  int len = snprintf(line, sizeof line, "%ld %s %s%s\n", index, kind, path, failed ? " FAILED" : "");
  if (len > (int)sizeof line) len = sizeof line;
  pthread_mutex_lock(&log_mutex);
  real_write(log_fd, line, (size_t)len);
  pthread_mutex_unlock(&log_mutex);
}

// Counts one mutating operation; true when it is the one to fail (errno is then set).
static int count_op(const char* kind, const char* path) {
  long index = atomic_fetch_add(&op_count, 1) + 1;
  int failed = fail_at > 0 && index == fail_at;
  log_line(index, kind, path, failed);
  if (failed) errno = fail_errno;
  return failed;
}

static int count_fd_op(const char* kind, int fd) {
  char path[PATH_MAX];
  fd_path(fd, path, sizeof path);
  const char* k = kind;
  if (tracked[fd] & 4) k = strcmp(kind, "fsync") == 0 ? "dirfsync" : "dirfdatasync";
  return count_op(k, path);
}

static void track(int fd, const char* abs) {
  if (fd < 0 || fd >= kMaxFds) return;
  struct stat st;
  unsigned char v = strstr(abs, read_match) ? 2 : 1;
  if (fstat(fd, &st) == 0 && S_ISDIR(st.st_mode)) v |= 4;
  tracked[fd] = v;
}

static int writes(int flags) { return (flags & (O_WRONLY | O_RDWR | O_CREAT | O_TRUNC)) != 0; }

static int do_open(int dirfd, const char* path, int flags, mode_t mode, int use64) {
  char abs[PATH_MAX];
  int in = inside(dirfd, path, abs, sizeof abs);
  if (in && writes(flags) && count_op((flags & O_CREAT) ? "create" : "open-write", abs)) return -1;
  int fd;
  if (dirfd == AT_FDCWD)
    fd = use64 ? real_open64(path, flags, mode) : real_open(path, flags, mode);
  else
    fd = use64 ? real_openat64(dirfd, path, flags, mode) : real_openat(dirfd, path, flags, mode);
  if (in) track(fd, abs);
  return fd;
}

static mode_t mode_arg(int flags, va_list ap) {
  return (flags & (O_CREAT | __O_TMPFILE)) ? (mode_t)va_arg(ap, int) : 0;
}

int open(const char* path, int flags, ...) {
  va_list ap;
  va_start(ap, flags);
  mode_t mode = mode_arg(flags, ap);
  va_end(ap);
  return do_open(AT_FDCWD, path, flags, mode, 0);
}

int open64(const char* path, int flags, ...) {
  va_list ap;
  va_start(ap, flags);
  mode_t mode = mode_arg(flags, ap);
  va_end(ap);
  return do_open(AT_FDCWD, path, flags, mode, 1);
}

int openat(int dirfd, const char* path, int flags, ...) {
  va_list ap;
  va_start(ap, flags);
  mode_t mode = mode_arg(flags, ap);
  va_end(ap);
  return do_open(dirfd, path, flags, mode, 0);
}

int openat64(int dirfd, const char* path, int flags, ...) {
  va_list ap;
  va_start(ap, flags);
  mode_t mode = mode_arg(flags, ap);
  va_end(ap);
  return do_open(dirfd, path, flags, mode, 1);
}

int creat(const char* path, mode_t mode) { return do_open(AT_FDCWD, path, O_WRONLY | O_CREAT | O_TRUNC, mode, 0); }

static FILE* do_fopen(const char* path, const char* how, int use64) {
  char abs[PATH_MAX];
  int in = inside(AT_FDCWD, path, abs, sizeof abs);
  if (in && strpbrk(how, "wa+") && count_op("create", abs)) return NULL;
  FILE* f = use64 ? real_fopen64(path, how) : real_fopen(path, how);
  if (in && f) track(fileno(f), abs);
  return f;
}

FILE* fopen(const char* path, const char* how) { return do_fopen(path, how, 0); }
FILE* fopen64(const char* path, const char* how) { return do_fopen(path, how, 1); }

int fclose(FILE* f) {
  ensure_init();
  int fd = fileno(f);
  if (fd >= 0 && fd < kMaxFds) tracked[fd] = 0;
  return real_fclose(f);
}

int close(int fd) {
  ensure_init();
  if (fd >= 0 && fd < kMaxFds) tracked[fd] = 0;
  return real_close(fd);
}

ssize_t write(int fd, const void* buf, size_t n) {
  if (fd_inside(fd) && count_fd_op("write", fd)) return -1;
  return real_write(fd, buf, n);
}

ssize_t pwrite(int fd, const void* buf, size_t n, off_t off) {
  if (fd_inside(fd) && count_fd_op("pwrite", fd)) return -1;
  return real_pwrite(fd, buf, n, off);
}

ssize_t pwrite64(int fd, const void* buf, size_t n, off64_t off) {
  if (fd_inside(fd) && count_fd_op("pwrite", fd)) return -1;
  return real_pwrite64(fd, buf, n, off);
}

ssize_t writev(int fd, const struct iovec* iov, int cnt) {
  if (fd_inside(fd) && count_fd_op("write", fd)) return -1;
  return real_writev(fd, iov, cnt);
}

ssize_t pwritev(int fd, const struct iovec* iov, int cnt, off_t off) {
  if (fd_inside(fd) && count_fd_op("pwrite", fd)) return -1;
  return real_pwritev(fd, iov, cnt, off);
}

size_t fwrite(const void* buf, size_t size, size_t n, FILE* f) {
  ensure_init();
  int fd = fileno(f);
  if (fd_inside(fd) && count_fd_op("write", fd)) return 0;
  return real_fwrite(buf, size, n, f);
}

int fsync(int fd) {
  if (fd_inside(fd) && count_fd_op("fsync", fd)) return -1;
  return real_fsync(fd);
}

int fdatasync(int fd) {
  if (fd_inside(fd) && count_fd_op("fdatasync", fd)) return -1;
  return real_fdatasync(fd);
}

// A copy of a commit's file as it was put in place (FAULT_KEEP).
static void keep(const char* abs) {
  if (!keep_dir[0]) return;
  const char* name = strrchr(abs, '/') + 1;
  if ((size_t)(name - abs) != dir_len + 1) return;  // only files at the top of the folder
  if (strcmp(name, "manifest.txt") && strcmp(name, "keyframes.txt") && strcmp(name, "run_state.json")) return;
  char out[PATH_MAX];
  snprintf(out, sizeof out, "%s/%06ld-%s", keep_dir, atomic_fetch_add(&keep_seq, 1), name);
  int in = real_open(abs, O_RDONLY | O_CLOEXEC);
  int to = real_open(out, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  char buf[65536];
  ssize_t got;
  while (in >= 0 && to >= 0 && (got = real_read(in, buf, sizeof buf)) > 0) real_write(to, buf, (size_t)got);
  if (in >= 0) real_close(in);
  if (to >= 0) real_close(to);
}

static int do_rename(int olddir, const char* from, int newdir, const char* to, unsigned flags, int at) {
  char a[PATH_MAX], b[PATH_MAX];
  int in_from = inside(olddir, from, a, sizeof a), in_to = inside(newdir, to, b, sizeof b);
  if ((in_from || in_to) && count_op("rename", in_to ? b : a)) return -1;
  int r = at == 2 ? real_renameat2(olddir, from, newdir, to, flags)
          : at    ? real_renameat(olddir, from, newdir, to)
                  : real_rename(from, to);
  if (r == 0 && in_to) keep(b);
  return r;
}

int rename(const char* from, const char* to) { return do_rename(AT_FDCWD, from, AT_FDCWD, to, 0, 0); }
int renameat(int od, const char* from, int nd, const char* to) { return do_rename(od, from, nd, to, 0, 1); }
int renameat2(int od, const char* from, int nd, const char* to, unsigned flags) {
  return do_rename(od, from, nd, to, flags, 2);
}

int mkdir(const char* path, mode_t mode) {
  char abs[PATH_MAX];
  if (inside(AT_FDCWD, path, abs, sizeof abs) && count_op("mkdir", abs)) return -1;
  return real_mkdir(path, mode);
}

int mkdirat(int dirfd, const char* path, mode_t mode) {
  char abs[PATH_MAX];
  if (inside(dirfd, path, abs, sizeof abs) && count_op("mkdir", abs)) return -1;
  return real_mkdirat(dirfd, path, mode);
}

int unlink(const char* path) {
  char abs[PATH_MAX];
  if (inside(AT_FDCWD, path, abs, sizeof abs) && count_op("unlink", abs)) return -1;
  return real_unlink(path);
}

int unlinkat(int dirfd, const char* path, int flags) {
  char abs[PATH_MAX];
  if (inside(dirfd, path, abs, sizeof abs) && count_op("unlink", abs)) return -1;
  return real_unlinkat(dirfd, path, flags);
}

int rmdir(const char* path) {
  char abs[PATH_MAX];
  if (inside(AT_FDCWD, path, abs, sizeof abs) && count_op("rmdir", abs)) return -1;
  return real_rmdir(path);
}

int remove(const char* path) {
  char abs[PATH_MAX];
  if (inside(AT_FDCWD, path, abs, sizeof abs) && count_op("unlink", abs)) return -1;
  return real_remove(path);
}

// A read fault: the chosen read of a matching descriptor returns EIO, as a bad sector would.
static int read_fault(int fd) {
  ensure_init();
  if (read_fail_at <= 0 || fd < 0 || fd >= kMaxFds || !(tracked[fd] & 2)) return 0;
  long index = atomic_fetch_add(&read_count, 1) + 1;
  char path[PATH_MAX];
  if (index != read_fail_at) return 0;
  log_line(index, "read", fd_path(fd, path, sizeof path), 1);
  errno = EIO;
  return 1;
}

ssize_t read(int fd, void* buf, size_t n) {
  if (read_fault(fd)) return -1;
  return real_read(fd, buf, n);
}

ssize_t pread(int fd, void* buf, size_t n, off_t off) {
  if (read_fault(fd)) return -1;
  return real_pread(fd, buf, n, off);
}

ssize_t pread64(int fd, void* buf, size_t n, off64_t off) {
  if (read_fault(fd)) return -1;
  return real_pread64(fd, buf, n, off);
}
