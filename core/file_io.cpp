#include "core/file_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace meshmux {

std::string base_name(const std::string& path) {
  size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

Result<std::vector<uint8_t>> read_whole_file(const std::string& path, uint64_t max_bytes) {
  // Opened without blocking and checked on the descriptor (no race with a path swap): only a
  // regular file is read, so a FIFO, /dev/stdin or /dev/zero never hangs or floods us.
  int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    if (errno == ENOENT) return Status::error(path + ": no such file", ErrorKind::kInput);
    return Status::error(path + ": cannot open: " + std::strerror(errno), ErrorKind::kInput);
  }
  struct stat st;
  if (fstat(fd, &st) != 0) {
    int e = errno;
    close(fd);
    return Status::error(path + ": cannot open: " + std::strerror(e), ErrorKind::kInput);
  }
  if (!S_ISREG(st.st_mode)) {
    close(fd);
    if (S_ISDIR(st.st_mode))
      return Status::error(path + ": is a directory, not a file", ErrorKind::kInput);
    return Status::error(path + ": not a regular file (a device, pipe or socket is not read)",
                         ErrorKind::kInput);
  }
  if (uint64_t(st.st_size) > max_bytes) {
    close(fd);
    return Status::error(path + ": file is " + std::to_string(st.st_size) +
                             " bytes, over the limit of " + std::to_string(max_bytes),
                         ErrorKind::kInput);
  }
  // Back to blocking reads (a regular file never blocks long).
  fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  std::vector<uint8_t> bytes;
  bytes.reserve(size_t(st.st_size));
  uint8_t buf[1 << 16];
  for (;;) {
    ssize_t n = read(fd, buf, sizeof buf);
    if (n < 0) {
      if (errno == EINTR) continue;
      int e = errno;
      close(fd);
      return Status::error(path + ": cannot read: " + std::strerror(e), ErrorKind::kInput);
    }
    if (n == 0) break;
    bytes.insert(bytes.end(), buf, buf + n);
    if (bytes.size() > max_bytes) {
      close(fd);
      return Status::error(
          path + ": file is over the limit of " + std::to_string(max_bytes) + " bytes",
          ErrorKind::kInput);
    }
  }
  close(fd);
  return bytes;
}

Result<InputScope> input_scope(const std::string& model_path, bool allow_outside,
                               const std::string& root) {
  std::string dir = root.empty() ? "." : root;
  size_t slash = model_path.find_last_of('/');
  if (root.empty() && slash != std::string::npos)
    dir = slash == 0 ? "/" : model_path.substr(0, slash);
  char* real = realpath(dir.c_str(), nullptr);
  if (!real)
    return Status::error(model_path + ": cannot resolve its folder: " + std::strerror(errno),
                         ErrorKind::kInput);
  InputScope scope;
  scope.root = real;
  free(real);
  scope.allow_outside = allow_outside;
  return scope;
}

Result<std::string> resolve_in_scope(const InputScope& scope, const std::string& path) {
  char* real = realpath(path.c_str(), nullptr);
  if (!real) {
    if (errno == ENOENT || errno == ENOTDIR)
      return Status::error(path + ": no such file", ErrorKind::kInput);
    return Status::error(path + ": cannot resolve: " + std::strerror(errno), ErrorKind::kInput);
  }
  std::string resolved = real;
  free(real);
  const std::string& root = scope.root;
  const bool inside =
      root == "/" || (resolved.size() > root.size() &&
                      resolved.compare(0, root.size(), root) == 0 && resolved[root.size()] == '/');
  if (!inside && !scope.allow_outside)
    return Status::error(path + ": outside the upload's folder " + root +
                             " (after resolving '..' and links); refused (upload the whole "
                             "folder or a .zip, or widen it with --root DIR; --allow-outside "
                             "reads it for trusted local files)",
                         ErrorKind::kInput);
  return resolved;
}

Status write_file_atomic(const std::string& path, const void* data, size_t size) {
  // Created exclusively and never through a link: a planted "<path>.tmp-<pid>" symlink is
  // removed (unlink removes the link, not its target) and the file created afresh.
  std::string tmp = path + ".tmp-" + std::to_string(getpid());
  const int flags = O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC;
  int fd = open(tmp.c_str(), flags, 0644);
  if (fd < 0 && errno == EEXIST && unlink(tmp.c_str()) == 0) fd = open(tmp.c_str(), flags, 0644);
  if (fd < 0)
    return Status::error(path + ": cannot create: " + std::strerror(errno), ErrorKind::kOutput);
  const uint8_t* p = static_cast<const uint8_t*>(data);
  size_t left = size;
  while (left > 0) {
    ssize_t n = write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      int e = errno;
      close(fd);
      unlink(tmp.c_str());
      return Status::error(path + ": cannot write: " + std::strerror(e), ErrorKind::kOutput);
    }
    p += n;
    left -= size_t(n);
  }
  if (fsync(fd) != 0 && errno != EINVAL) {
    int e = errno;
    close(fd);
    unlink(tmp.c_str());
    return Status::error(path + ": cannot write: " + std::strerror(e), ErrorKind::kOutput);
  }
  close(fd);
  if (rename(tmp.c_str(), path.c_str()) != 0) {
    int e = errno;
    unlink(tmp.c_str());
    return Status::error(path + ": cannot rename into place: " + std::strerror(e),
                         ErrorKind::kOutput);
  }
  return Status::ok();
}

}  // namespace meshmux
