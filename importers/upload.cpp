#include "importers/upload.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zip.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <set>

#include "core/file_io.h"

namespace meshmux {
namespace fs = std::filesystem;

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

bool ends_with_ci(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && lower(s.substr(s.size() - suffix.size())) == suffix;
}

bool is_model_name(const std::string& name) {
  return ends_with_ci(name, ".gltf") || ends_with_ci(name, ".glb") || ends_with_ci(name, ".dae");
}

// Entries a walk never descends into or offers: hidden ones (".git", "._x" resource forks)
// and macOS archivers' "__MACOSX" folder of resource forks.
bool is_junk(const std::string& leaf) { return leaf.empty() || leaf[0] == '.' || leaf == "__MACOSX"; }

std::string real_path(const std::string& path) {
  char* r = realpath(path.c_str(), nullptr);
  if (!r) return "";
  std::string s = r;
  free(r);
  return s;
}

bool is_inside(const std::string& root, const std::string& resolved) {
  return root == "/" || (resolved.size() > root.size() && resolved.compare(0, root.size(), root) == 0 &&
                         resolved[root.size()] == '/');
}

// The model files nearest the root of a folder upload (sorted, relative to the root).
Result<std::vector<std::string>> nearest_models(const std::string& root, const std::string& what,
                                                uint64_t max_entries) {
  std::vector<std::string> best;
  size_t best_depth = SIZE_MAX;
  uint64_t seen = 0;
  std::error_code ec;
  fs::recursive_directory_iterator it(root, fs::directory_options::skip_permission_denied, ec);
  if (ec)
    return Status::error("upload: " + what + ": cannot read the folder: " + ec.message(),
                         ErrorKind::kInput);
  for (; it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (ec)
      return Status::error("upload: " + what + ": cannot walk the folder: " + ec.message(),
                           ErrorKind::kInput);
    if (++seen > max_entries)
      return Status::error("upload: " + what + ": more than " + std::to_string(max_entries) +
                               " entries; name the model file with --main PATH",
                           ErrorKind::kInput);
    const std::string leaf = it->path().filename().string();
    std::error_code e2;
    const bool dir = it->is_directory(e2);
    if (is_junk(leaf)) {
      if (dir) it.disable_recursion_pending();
      continue;
    }
    // Nothing deeper than the best found so far can win.
    if (dir) {
      if (size_t(it.depth()) + 1 > best_depth) it.disable_recursion_pending();
      continue;
    }
    if (!is_model_name(leaf) || !it->is_regular_file(e2)) continue;
    const size_t depth = size_t(it.depth());
    if (depth > best_depth) continue;
    if (depth < best_depth) best.clear(), best_depth = depth;
    best.push_back(fs::path(it->path()).lexically_relative(root).string());
  }
  std::sort(best.begin(), best.end());
  return best;
}

// The model file of a folder upload: `main`, or the one nearest the root.
Result<std::string> pick_model(const std::string& root, const std::string& what,
                               const UploadOptions& o) {
  if (!o.main.empty()) {
    const std::string full = (fs::path(root) / o.main).lexically_normal().string();
    const std::string resolved = real_path(full);
    if (resolved.empty())
      return Status::error("upload: " + what + ": --main " + o.main + ": no such file inside it",
                           ErrorKind::kInput);
    if (!is_inside(root, resolved))
      return Status::error("upload: " + what + ": --main " + o.main + " lies outside it; refused",
                           ErrorKind::kInput);
    return resolved;
  }
  auto found = nearest_models(root, what, o.max_walk_entries);
  if (!found) return found.status();
  if (found->empty())
    return Status::error("upload: " + what + ": no .gltf, .glb or .dae file inside it",
                         ErrorKind::kInput);
  if (found->size() > 1) {
    std::string list;
    for (size_t i = 0; i < found->size() && i < 8; ++i) list += (i ? ", " : "") + (*found)[i];
    if (found->size() > 8) list += ", ... (" + std::to_string(found->size()) + " in all)";
    return Status::error("upload: " + what + ": several model files at the same depth (" + list +
                             "); name one with --main PATH",
                         ErrorKind::kInput);
  }
  return root + "/" + found->front();
}

// A member's path, checked and normalised ("a//./b" → "a/b"; '\\' counts as '/', as Windows
// tools write it). "" with `why` set when the member must be refused.
std::string member_path(const std::string& raw, std::string* why) {
  std::string name = raw;
  std::replace(name.begin(), name.end(), '\\', '/');
  if (name.empty()) return *why = "has an empty name", "";
  if (name[0] == '/') return *why = "has an absolute path", "";
  std::vector<std::string> parts;
  size_t at = 0;
  while (at <= name.size()) {
    size_t slash = name.find('/', at);
    if (slash == std::string::npos) slash = name.size();
    std::string part = name.substr(at, slash - at);
    at = slash + 1;
    if (part.empty() || part == ".") continue;
    if (part == "..") return *why = "leaves the archive ('..')", "";
    if (parts.empty() && part.size() >= 2 && part[1] == ':') return *why = "has a drive letter", "";
    parts.push_back(part);
  }
  if (parts.empty()) return *why = "has an empty name", "";
  std::string out;
  for (const std::string& p : parts) out += (out.empty() ? "" : "/") + p;
  return out;
}

// One checked member of an archive.
struct Member {
  zip_uint64_t index = 0;
  std::string path;  // normalised, relative
  bool dir = false;
  uint64_t size = 0;  // as declared
};

std::string zip_message(int code) {
  zip_error_t e;
  zip_error_init_with_code(&e, code);
  std::string s = zip_error_strerror(&e);
  zip_error_fini(&e);
  return s;
}

// Checks every member before anything is written (see the header's refusals).
Result<std::vector<Member>> check_members(zip_t* za, const std::string& what,
                                          const UploadOptions& o, uint64_t limit) {
  const zip_int64_t n = zip_get_num_entries(za, 0);
  if (n < 0) return Status::error("upload: " + what + ": cannot list the archive", ErrorKind::kInput);
  if (uint64_t(n) > o.max_members)
    return Status::error("upload: " + what + ": " + std::to_string(n) + " members, over the limit of " +
                             std::to_string(o.max_members) + "; refused",
                         ErrorKind::kInput);
  std::vector<Member> members;
  std::set<std::string> names;
  uint64_t declared = 0;
  for (zip_int64_t i = 0; i < n; ++i) {
    zip_stat_t st;
    zip_stat_init(&st);
    if (zip_stat_index(za, zip_uint64_t(i), 0, &st) != 0 || !(st.valid & ZIP_STAT_NAME))
      return Status::error("upload: " + what + ": member " + std::to_string(i) + " cannot be read",
                           ErrorKind::kInput);
    const std::string raw = st.name;
    const std::string shown = "member '" + raw + "'";
    std::string why;
    Member m;
    m.index = zip_uint64_t(i);
    m.path = member_path(raw, &why);
    if (m.path.empty())
      return Status::error("upload: " + what + ": " + shown + " " + why + "; refused", ErrorKind::kInput);
    m.dir = !raw.empty() && (raw.back() == '/' || raw.back() == '\\');
    zip_uint8_t opsys = 0;
    zip_uint32_t attributes = 0;
    if (zip_file_get_external_attributes(za, zip_uint64_t(i), 0, &opsys, &attributes) == 0 &&
        opsys == ZIP_OPSYS_UNIX) {
      const mode_t mode = mode_t(attributes >> 16);
      if (S_ISLNK(mode))
        return Status::error("upload: " + what + ": " + shown + " is a symbolic link; refused",
                             ErrorKind::kInput);
      if (S_ISCHR(mode) || S_ISBLK(mode) || S_ISFIFO(mode) || S_ISSOCK(mode))
        return Status::error("upload: " + what + ": " + shown + " is a device, FIFO or socket; refused",
                             ErrorKind::kInput);
      if (S_ISDIR(mode)) m.dir = true;
    }
    if ((st.valid & ZIP_STAT_ENCRYPTION_METHOD) && st.encryption_method != ZIP_EM_NONE)
      return Status::error("upload: " + what + ": " + shown + " is encrypted; refused", ErrorKind::kInput);
    if (!names.insert(lower(m.path)).second && !m.dir)
      return Status::error("upload: " + what + ": " + shown + " appears twice; refused", ErrorKind::kInput);
    m.size = (st.valid & ZIP_STAT_SIZE) ? st.size : 0;
    declared += m.size;
    if (declared > limit)
      return Status::error("upload: " + what + ": unpacks to more than " + std::to_string(limit) +
                               " bytes (the limit from the archive's size); refused",
                           ErrorKind::kInput);
    members.push_back(std::move(m));
  }
  return members;
}

// Creates the folders of `rel` below `base` (mode 0700, never through a link).
Status make_parents(const std::string& base, const std::string& rel, const std::string& what) {
  size_t at = 0;
  while ((at = rel.find('/', at)) != std::string::npos) {
    const std::string dir = base + "/" + rel.substr(0, at);
    ++at;
    struct stat st;
    if (lstat(dir.c_str(), &st) == 0) {
      if (S_ISDIR(st.st_mode)) continue;
      return Status::error("upload: " + what + ": member '" + rel + "' lies below a file; refused",
                           ErrorKind::kInput);
    }
    if (mkdir(dir.c_str(), 0700) != 0)
      return Status::error("upload: " + what + ": cannot unpack '" + rel + "': " + std::strerror(errno),
                           ErrorKind::kOutput);
  }
  return Status::ok();
}

// Inflates one member into base/path, counting real bytes against `*left`.
Status unpack_member(zip_t* za, const Member& m, const std::string& base, const std::string& what,
                     uint64_t limit, uint64_t* left) {
  if (Status s = make_parents(base, m.path + (m.dir ? "/" : ""), what); !s) return s;
  if (m.dir) return Status::ok();
  const std::string dest = base + "/" + m.path;
  int fd = open(dest.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0)
    return Status::error("upload: " + what + ": member '" + m.path +
                             (errno == EEXIST ? "' appears twice; refused" : "' cannot be unpacked: " +
                                                                                 std::string(std::strerror(errno))),
                         errno == EEXIST ? ErrorKind::kInput : ErrorKind::kOutput);
  zip_file_t* zf = zip_fopen_index(za, m.index, 0);
  if (!zf) {
    close(fd);
    return Status::error("upload: " + what + ": member '" + m.path + "' cannot be read: " +
                             zip_strerror(za),
                         ErrorKind::kInput);
  }
  Status result = Status::ok();
  std::vector<char> buf(1 << 16);
  for (;;) {
    const zip_int64_t got = zip_fread(zf, buf.data(), buf.size());
    if (got < 0) {
      result = Status::error("upload: " + what + ": member '" + m.path + "' is damaged: " +
                                 zip_file_strerror(zf),
                             ErrorKind::kInput);
      break;
    }
    if (got == 0) break;
    if (uint64_t(got) > *left) {
      result = Status::error("upload: " + what + ": unpacks to more than " + std::to_string(limit) +
                                 " bytes (the limit from the archive's size); refused",
                             ErrorKind::kInput);
      break;
    }
    *left -= uint64_t(got);
    for (zip_int64_t done = 0; done < got;) {
      const ssize_t w = write(fd, buf.data() + done, size_t(got - done));
      if (w < 0 && errno == EINTR) continue;
      if (w < 0) {
        result = Status::error("upload: " + what + ": cannot unpack '" + m.path + "': " +
                                   std::strerror(errno),
                               ErrorKind::kOutput);
        break;
      }
      done += w;
    }
    if (!result) break;
  }
  zip_fclose(zf);
  close(fd);
  return result;
}

// Unpacks a checked archive into `scratch` (created here).
Status unpack_zip(const std::string& path, const std::string& what, const UploadOptions& o,
                  const std::string& scratch) {
  struct stat st;
  if (stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode))
    return Status::error("upload: " + what + ": not a regular file", ErrorKind::kInput);
  const uint64_t limit = o.max_unpacked_bytes
                             ? o.max_unpacked_bytes
                             : std::max<uint64_t>(uint64_t(512) << 20, 64 * uint64_t(st.st_size));
  int code = 0;
  zip_t* za = zip_open(path.c_str(), ZIP_RDONLY, &code);
  if (!za)
    return Status::error("upload: " + what + ": not a readable zip archive (" + zip_message(code) + ")",
                         ErrorKind::kInput);
  Status result = Status::ok();
  auto members = check_members(za, what, o, limit);
  if (!members) {
    result = members.status();
  } else if (mkdir(scratch.c_str(), 0700) != 0) {
    result = Status::error("upload: " + what + ": cannot create " + scratch + " to unpack it: " +
                               std::strerror(errno),
                           ErrorKind::kOutput);
  } else {
    uint64_t left = limit;
    for (const Member& m : *members)
      if (result = unpack_member(za, m, scratch, what, limit, &left); !result) break;
  }
  zip_discard(za);
  return result;
}

bool has_zip_magic(const std::string& path) {
  int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return false;
  struct stat st;
  char head[4] = {};
  const bool ok = fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && read(fd, head, 4) == 4;
  close(fd);
  return ok && std::memcmp(head, "PK\3\4", 4) == 0;
}

}  // namespace

Upload::Upload(Upload&& o) noexcept { *this = std::move(o); }

Upload& Upload::operator=(Upload&& o) noexcept {
  if (this == &o) return *this;
  remove_scratch();
  root_ = std::move(o.root_), model_ = std::move(o.model_), display_ = std::move(o.display_);
  scratch_ = std::move(o.scratch_);
  o.scratch_.clear();
  return *this;
}

Upload::~Upload() { remove_scratch(); }

void Upload::remove_scratch() {
  if (scratch_.empty()) return;
  std::error_code ec;
  fs::remove_all(scratch_, ec);
  scratch_.clear();
}

Result<Upload> open_upload(const std::string& path, const UploadOptions& o,
                           const std::string& scratch) {
  const std::string what = base_name(path.size() > 1 && path.back() == '/'
                                         ? path.substr(0, path.size() - 1)
                                         : path);
  std::error_code ec;
  Upload up;
  if (!fs::exists(path, ec))
    return Status::error("upload: " + path + ": no such file or folder", ErrorKind::kInput);
  if (fs::is_directory(path, ec) || ends_with_ci(path, ".zip") || has_zip_magic(path)) {
    std::string folder = path;
    if (!fs::is_directory(path, ec)) {
      if (Status s = unpack_zip(path, what, o, scratch); !s) {
        fs::remove_all(scratch, ec);
        return s;
      }
      up.scratch_ = scratch;
      folder = scratch;
    }
    up.root_ = real_path(folder);
    if (up.root_.empty())
      return Status::error("upload: " + what + ": cannot resolve the folder", ErrorKind::kInput);
    auto model = pick_model(up.root_, what, o);
    if (!model) return model.status();
    up.model_ = *model;
    const std::string rel = fs::path(up.model_).lexically_relative(up.root_).string();
    up.display_ = up.unpacked() ? what + ":" + rel : (fs::path(path) / rel).lexically_normal().string();
    return up;
  }
  // A lone model file.
  const std::string file = real_path(path);
  if (file.empty())
    return Status::error("upload: " + path + ": cannot resolve: " + std::strerror(errno),
                         ErrorKind::kInput);
  if (o.root.empty()) {
    up.root_ = fs::path(file).parent_path().string();
  } else {
    up.root_ = real_path(o.root);
    if (up.root_.empty() || !fs::is_directory(up.root_, ec))
      return Status::error("upload: --root " + o.root + ": no such folder", ErrorKind::kInput);
    if (!is_inside(up.root_, file))
      return Status::error("upload: " + what + " lies outside --root " + o.root + "; refused",
                           ErrorKind::kInput);
  }
  up.model_ = path;
  up.display_ = path;
  return up;
}

std::vector<std::string> find_by_file_name(const std::string& root, const std::string& name,
                                           uint64_t max_entries) {
  std::vector<std::string> found;
  const std::string want = lower(name);
  if (want.empty()) return found;
  uint64_t seen = 0;
  std::error_code ec;
  fs::recursive_directory_iterator it(root, fs::directory_options::skip_permission_denied, ec);
  for (; !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (++seen > max_entries) break;
    const std::string leaf = it->path().filename().string();
    std::error_code e2;
    if (is_junk(leaf)) {
      if (it->is_directory(e2)) it.disable_recursion_pending();
      continue;
    }
    if (lower(leaf) == want && it->is_regular_file(e2) && !it->is_symlink(e2))
      found.push_back(it->path().string());
  }
  std::sort(found.begin(), found.end());
  return found;
}

}  // namespace meshmux
