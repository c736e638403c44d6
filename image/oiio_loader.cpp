// dlopen of the OpenImageIO module (see oiio_loader.h and image/oiio/oiio_codec.h for why).
#include "image/oiio_loader.h"

#include <dlfcn.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <vector>

#include "image/oiio/oiio_codec.h"

namespace meshmux {

namespace {

using DecodeFn = int (*)(const uint8_t*, size_t, const char*, uint64_t, MeshmuxOiioImage*, char*,
                         size_t);
using FreeFn = void (*)(uint8_t*);

struct Module {
  DecodeFn decode = nullptr;
  FreeFn release = nullptr;
  std::string error;  // why it could not be loaded
};

std::atomic<bool> g_loaded{false};

std::string executable_dir() {
  char buf[4096];
  ssize_t n = readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) return "";
  std::string path(buf, size_t(n));
  size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? "" : path.substr(0, slash);
}

const Module& module() {
  static Module m;
  static std::once_flag once;
  std::call_once(once, [] {
    std::vector<std::string> candidates;
    if (const char* env = std::getenv("MESHMUX_OIIO_MODULE"); env && *env)
      candidates.push_back(env);
    if (std::string dir = executable_dir(); !dir.empty())
      candidates.push_back(dir + "/" MESHMUX_OIIO_MODULE);
#ifdef MESHMUX_OIIO_MODULE_DIR
    candidates.push_back(std::string(MESHMUX_OIIO_MODULE_DIR) + "/" MESHMUX_OIIO_MODULE);
#endif
    std::string tried;
    for (const std::string& path : candidates) {
      if (access(path.c_str(), R_OK) != 0) {
        tried += (tried.empty() ? "" : ", ") + path;
        continue;
      }
      void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (!handle) {
        const char* e = dlerror();
        m.error = "cannot load " + path + ": " + (e ? e : "dlopen failed");
        return;
      }
      m.decode = reinterpret_cast<DecodeFn>(dlsym(handle, "meshmux_oiio_decode"));
      m.release = reinterpret_cast<FreeFn>(dlsym(handle, "meshmux_oiio_free"));
      if (!m.decode || !m.release) {
        m.error = path + " lacks the decoder's entry points";
        m.decode = nullptr;
        return;
      }
      g_loaded = true;
      return;
    }
    m.error = "the OpenImageIO module " MESHMUX_OIIO_MODULE " is not installed (looked for " +
              tried + ")";
  });
  return m;
}

}  // namespace

bool oiio_module_loaded() { return g_loaded.load(); }

Status oiio_decode(Image& image, const std::string& format, uint64_t max_pixels, bool* over_limit) {
  const Module& m = module();
  if (!m.decode)
    return Status::error(image.name + ": cannot decode " + format + " image: " + m.error,
                         ErrorKind::kInternal);
  MeshmuxOiioImage out{0, 0, nullptr};
  char error[1024] = "";
  int rc = m.decode(image.encoded.data(), image.encoded.size(), format.c_str(), max_pixels, &out,
                    error, sizeof error);
  if (rc != kMeshmuxOiioOk) {
    if (over_limit && rc == kMeshmuxOiioOverLimit) *over_limit = true;
    return Status::error(image.name + ": " + error, ErrorKind::kInput);
  }
  const size_t n = size_t(out.width) * size_t(out.height) * 4;
  image.width = out.width;
  image.height = out.height;
  image.rgba.assign(out.rgba, out.rgba + n);
  m.release(out.rgba);
  return Status::ok();
}

}  // namespace meshmux
