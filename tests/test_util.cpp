#include "test_util.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "multiplex/render.h"

namespace fs = std::filesystem;

namespace meshmux::testing {

TempDir::TempDir() {
  std::string tmpl = (fs::temp_directory_path() / "meshmux-test-XXXXXX").string();
  std::vector<char> buf(tmpl.begin(), tmpl.end());
  buf.push_back('\0');
  char* p = mkdtemp(buf.data());
  if (!p) throw std::runtime_error("mkdtemp failed");
  path_ = p;
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

std::vector<std::string> TempDir::list() const {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(path_)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

static std::string slurp_fd(int fd) {
  std::string s;
  char buf[65536];
  ssize_t n;
  while ((n = read(fd, buf, sizeof buf)) > 0) s.append(buf, size_t(n));
  return s;
}

CommandResult run_program(const std::string& program, const std::vector<std::string>& args) {
  // stdout and stderr go to temp files (avoids pipe deadlocks without threads).
  TempDir tmp;
  std::string out_path = tmp.file("out"), err_path = tmp.file("err");
  pid_t pid = fork();
  if (pid == 0) {
    int o = open(out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    int e = open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    int in = open("/dev/null", O_RDONLY);
    dup2(o, 1);
    dup2(e, 2);
    dup2(in, 0);
    std::vector<char*> argv;
    argv.push_back(const_cast<char*>(program.c_str()));
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execvp(program.c_str(), argv.data());
    _exit(127);
  }
  CommandResult r;
  int status = 0;
  waitpid(pid, &status, 0);
  if (WIFEXITED(status))
    r.exit_code = WEXITSTATUS(status);
  else if (WIFSIGNALED(status))
    r.exit_code = 128 + WTERMSIG(status);
  int o = open(out_path.c_str(), O_RDONLY), e = open(err_path.c_str(), O_RDONLY);
  if (o >= 0) r.out = slurp_fd(o), close(o);
  if (e >= 0) r.err = slurp_fd(e), close(e);
  return r;
}

CommandResult run_meshmux(const std::vector<std::string>& args) {
  return run_program(MESHMUX_BINARY, args);
}

bool have_shared_models() { return fs::is_directory(std::string(MESHMUX_SHARED_DIR) + "/models"); }

std::string shared_model(const std::string& rel) {
  if (!have_shared_models()) return "";
  return std::string(MESHMUX_SHARED_DIR) + "/models/" + rel;
}

Primitive unit_quad(float x, int32_t material) {
  Primitive p;
  p.positions = {{x, 0, 0}, {x + 1, 0, 0}, {x + 1, 1, 0}, {x, 1, 0}};
  p.normals.assign(4, {0, 0, 1});
  p.uvs = {{{0, 0}, {1, 0}, {1, 1}, {0, 1}}};
  p.indices = {0, 1, 2, 0, 2, 3};
  p.material = material;
  return p;
}

Scene quads_with_own_textures(int count, int side) {
  Scene s;
  Mesh mesh;
  for (int k = 0; k < count; ++k) {
    Image img;
    img.width = img.height = side;
    for (int y = 0; y < side; ++y)
      for (int x = 0; x < side; ++x)
        img.rgba.insert(img.rgba.end(), {uint8_t(40 * k), uint8_t(x * 2), uint8_t(y * 2), 255});
    s.images.push_back(img);
    Material m;
    m.base_color.image = k;
    s.materials.push_back(m);
    mesh.primitives.push_back(unit_quad(2.0f * float(k), k));
  }
  s.meshes.push_back(mesh);
  s.instances.push_back({0, Mat4::identity(), ""});
  return s;
}

Primitive uv_sphere(int rings, int segments, float radius, Vec3 centre) {
  Primitive p;
  p.uvs.resize(1);
  for (int r = 0; r <= rings; ++r)
    for (int s = 0; s <= segments; ++s) {
      float th = float(M_PI) * float(r) / float(rings),
            ph = 2 * float(M_PI) * float(s % segments) / float(segments);
      Vec3 n{std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph)};
      if (r == 0 || r == rings) n = {0, r == 0 ? 1.0f : -1.0f, 0};
      p.positions.push_back(n * radius + centre);
      p.normals.push_back(n);
      p.uvs[0].push_back({float(s) / float(segments), float(r) / float(rings)});
    }
  auto id = [&](int r, int s) { return uint32_t(r * (segments + 1) + s); };
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      if (r > 0) p.indices.insert(p.indices.end(), {id(r, s), id(r, s + 1), id(r + 1, s)});
      if (r < rings - 1)
        p.indices.insert(p.indices.end(), {id(r, s + 1), id(r + 1, s + 1), id(r + 1, s)});
    }
  return p;
}

Scene bumpy_sphere(int rings, int segments) {
  Primitive p = uv_sphere(rings, segments);
  for (Vec3& v : p.positions) {
    const int64_t h = int64_t(std::lround(v.x * 997)) * 73856093 ^
                      int64_t(std::lround(v.y * 997)) * 19349663 ^
                      int64_t(std::lround(v.z * 997)) * 83492791;
    const float bump = 1.0f + 0.003f * float((h >> 3) % 11) / 10.0f;
    v = {v.x * bump, v.y * bump, v.z * bump};
  }
  Scene s;
  Mesh m;
  m.primitives.push_back(p);
  s.meshes.push_back(m);
  s.instances.push_back({0, Mat4::identity(), "bumpy"});
  return s;
}

std::string model_test_name(const std::string& relative_path) {
  std::string n = relative_path.substr(0, relative_path.find('/'));
  for (char& c : n)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return n;
}

std::vector<std::string> shared_model_files() {
  std::vector<std::string> files;
  if (!have_shared_models()) return files;
  for (const auto& dir : fs::directory_iterator(std::string(MESHMUX_SHARED_DIR) + "/models")) {
    if (!dir.is_directory()) continue;
    for (const auto& f : fs::directory_iterator(dir.path())) {
      std::string ext = f.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
      if (ext == ".dae" || ext == ".gltf" || ext == ".glb") files.push_back(f.path().string());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::vector<uint8_t> read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>((std::istreambuf_iterator<char>(in)),
                              std::istreambuf_iterator<char>());
}

void write_file(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

int gltf_validator_errors(const std::string& path, std::string* report) {
  std::string validator = std::string(MESHMUX_SOURCE_DIR) + "/tests/tools/validate_gltf.mjs";
  if (!fs::exists(std::string(MESHMUX_SOURCE_DIR) + "/node_modules/gltf-validator")) return -1;
  CommandResult r = run_program("node", {validator, path});
  if (report) *report = r.out + r.err;
  if (r.exit_code != 0 && r.exit_code != 1) return -1;
  try {
    auto j = nlohmann::json::parse(r.out);
    return j["issues"]["numErrors"].get<int>();
  } catch (...) {
    return -1;
  }
}

bool renderer_available(std::string* why) {
  static const std::string reason = [] {
    auto r = Renderer::create();
    if (!r.ok() && r.status().kind() == ErrorKind::kUnavailable) return r.status().message();
    return std::string();
  }();
  if (why) *why = reason;
  return reason.empty();
}

std::vector<uint8_t> ktx2_shell(uint32_t scheme, bool etc1s, size_t data_bytes) {
  std::vector<uint8_t> b = {0xAB, 'K', 'T', 'X', ' ', '2', '0', 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
  auto put = [&](uint32_t v) {
    for (int i = 0; i < 4; ++i) b.push_back(uint8_t(v >> (8 * i)));
  };
  const uint32_t dfd_offset = 80 + 24, dfd_length = 44;
  const uint32_t data_offset = dfd_offset + dfd_length;
  put(0), put(1), put(16), put(16), put(0), put(0), put(1), put(1), put(scheme);  // .. scheme
  put(dfd_offset), put(dfd_length), put(0), put(0);                               // dfd, kvd
  put(0), put(0), put(0), put(0);                                                 // sgd
  put(data_offset), put(0), put(uint32_t(data_bytes)), put(0), put(0), put(0);    // level 0
  put(dfd_length);                                                                // dfdTotalSize
  put(0), put(2 | (40u << 16));  // vendor/type, version 2 + block size 40
  b.push_back(etc1s ? 163 : 166), b.push_back(1), b.push_back(2), b.push_back(0);  // sRGB
  b.resize(data_offset + data_bytes, 0);
  return b;
}

}  // namespace meshmux::testing
