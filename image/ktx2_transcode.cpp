// KTX2 (Basis Universal) to RGBA8 through three.js's transcoder under Node.js (see
// image/ktx2_transcode.h). The transcoder's files are embedded with the assembler's .incbin
// (as exporters/viewer_page.cpp embeds the viewer): an installed meshmux does not depend on the
// source tree's node_modules, and the transcoder is the one of the three.js the viewer embeds.
#include "image/ktx2_transcode.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>

#include "core/file_io.h"
#include "core/process.h"
#include "core/scratch_dir.h"

#if !defined(MESHMUX_BASIS_TRANSCODER_JS) || !defined(MESHMUX_BASIS_TRANSCODER_WASM) || \
    !defined(MESHMUX_KTX2_TRANSCODER_SCRIPT)
#error "the build must name the Basis transcoder's files (CMakeLists.txt)"
#endif

// Each embedded file between a begin and an end symbol.
#define MESHMUX_EMBED(sym, path)                                                                  \
  __asm__(".section .rodata\n.balign 16\n.globl " #sym "_begin\n" #sym "_begin:\n.incbin \"" path \
          "\"\n.globl " #sym "_end\n" #sym "_end:\n.byte 0\n.previous\n")
MESHMUX_EMBED(meshmux_basis_js, MESHMUX_BASIS_TRANSCODER_JS);
MESHMUX_EMBED(meshmux_basis_wasm, MESHMUX_BASIS_TRANSCODER_WASM);
MESHMUX_EMBED(meshmux_ktx2_script, MESHMUX_KTX2_TRANSCODER_SCRIPT);
extern "C" const char meshmux_basis_js_begin[], meshmux_basis_js_end[];
extern "C" const char meshmux_basis_wasm_begin[], meshmux_basis_wasm_end[];
extern "C" const char meshmux_ktx2_script_begin[], meshmux_ktx2_script_end[];

namespace meshmux {

namespace {

uint32_t u32(const std::vector<uint8_t>& b, size_t at) {
  return uint32_t(b[at]) | uint32_t(b[at + 1]) << 8 | uint32_t(b[at + 2]) << 16 |
         uint32_t(b[at + 3]) << 24;
}
uint64_t u64(const std::vector<uint8_t>& b, size_t at) {
  return uint64_t(u32(b, at)) | uint64_t(u32(b, at + 4)) << 32;
}

Status bad(const std::string& why) { return Status::error(why, ErrorKind::kInput); }

constexpr size_t kHeaderBytes = 80;   // identifier + the fixed header + the index's offsets
constexpr size_t kLevelBytes = 24;    // one level index entry: offset, length, uncompressed
constexpr uint8_t kModelEtc1s = 163;  // KHR_DF_MODEL_ETC1S
constexpr uint8_t kModelUastc = 166;  // KHR_DF_MODEL_UASTC

// The transcoder's files and where they go in the run's folder.
struct Embedded {
  const char* name;
  const char* begin;
  const char* end;
};
const Embedded kEmbedded[] = {
    {"ktx2_transcoder.cjs", meshmux_ktx2_script_begin, meshmux_ktx2_script_end},
    {"basis_transcoder.cjs", meshmux_basis_js_begin, meshmux_basis_js_end},
    {"basis_transcoder.wasm", meshmux_basis_wasm_begin, meshmux_basis_wasm_end},
};

// Reads image k's answer from the run's folder into `image`.
Ktx2Decoded take_answer(const ScratchDir& dir, size_t k, const Ktx2Header& header, Image& image) {
  Ktx2Decoded out;
  const std::string stem = std::to_string(k);
  auto err = read_whole_file(dir.file(stem + ".err"), 4096);
  if (err.ok()) {
    std::string why(err->begin(), err->end());
    out.status = bad(image.name + ": KTX2: " + last_output_line(why));
    return out;
  }
  auto rgba = read_whole_file(dir.file(stem + ".rgba"));
  const uint64_t want = 8 + uint64_t(header.width) * uint64_t(header.height) * 4;
  if (!rgba.ok() || rgba->size() != want || u32(*rgba, 0) != uint32_t(header.width) ||
      u32(*rgba, 4) != uint32_t(header.height)) {
    out.status =
        Status::error(image.name + ": KTX2: the transcoder gave no image", ErrorKind::kInternal);
    return out;
  }
  image.rgba.assign(rgba->begin() + 8, rgba->end());
  image.width = header.width;
  image.height = header.height;
  return out;
}

}  // namespace

Result<Ktx2Header> read_ktx2_header(const std::vector<uint8_t>& b) {
  static const uint8_t kIdentifier[12] = {0xAB, 'K',  'T',  'X',  ' ',  '2',
                                          '0',  0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
  if (b.size() < sizeof kIdentifier || std::memcmp(b.data(), kIdentifier, sizeof kIdentifier) != 0)
    return bad("not a KTX2 file (its first 12 bytes are not KTX2's identifier)");
  if (b.size() < kHeaderBytes + kLevelBytes) return bad("truncated header");
  Ktx2Header h;
  const uint32_t vk_format = u32(b, 12), width = u32(b, 20), height = u32(b, 24);
  const uint32_t depth = u32(b, 28), faces = u32(b, 36);
  h.levels = std::max<uint32_t>(1, u32(b, 40));
  h.supercompression = u32(b, 44);
  const uint32_t dfd_offset = u32(b, 48), dfd_length = u32(b, 52);
  if (vk_format != 0)
    return bad("vkFormat " + std::to_string(vk_format) +
               ": not Basis Universal (only ETC1S and UASTC KTX2 are read)");
  if (width == 0 || height == 0 || width > (1u << 16) || height > (1u << 16))
    return bad("size " + std::to_string(width) + "x" + std::to_string(height) + " out of range");
  if (depth > 1 || faces != 1) return bad("a 3D texture or a cube map, not a 2D image");
  if (h.levels > 32) return bad(std::to_string(h.levels) + " mip levels (at most 32)");
  if (b.size() < kHeaderBytes + uint64_t(h.levels) * kLevelBytes)
    return bad("truncated level index");
  const uint64_t level_offset = u64(b, kHeaderBytes), level_length = u64(b, kHeaderBytes + 8);
  if (level_length == 0 || level_offset > b.size() || level_length > b.size() - level_offset)
    return bad("level 0's data lies outside the file (truncated?)");
  if (uint64_t(dfd_offset) + 16 > b.size() || dfd_length < 16 ||
      uint64_t(dfd_offset) + dfd_length > b.size())
    return bad("data format descriptor outside the file (truncated?)");
  const uint8_t model = b[dfd_offset + 12];
  h.srgb = b[dfd_offset + 14] == 2;  // KHR_DF_TRANSFER_SRGB
  const char* schemes[] = {"none", "BasisLZ", "Zstandard", "ZLIB"};
  const std::string scheme =
      h.supercompression < 4 ? schemes[h.supercompression] : std::to_string(h.supercompression);
  if (model == kModelEtc1s && h.supercompression == 1) {
    h.etc1s = true;
  } else if (model == kModelUastc && (h.supercompression == 0 || h.supercompression == 2)) {
    h.etc1s = false;
  } else if (model == kModelEtc1s || model == kModelUastc) {
    return bad(std::string(model == kModelEtc1s ? "ETC1S" : "UASTC") + " with supercompression " +
               scheme + ", which the Basis transcoder does not read");
  } else {
    return bad("colour model " + std::to_string(model) +
               ": not Basis Universal ETC1S or UASTC (supercompression " + scheme + ")");
  }
  h.width = int(width);
  h.height = int(height);
  return h;
}

Status write_ktx2_transcoder(const std::string& dir) {
  for (const Embedded& e : kEmbedded) {
    Status s = write_file_atomic(dir + "/" + e.name, e.begin, size_t(e.end - e.begin));
    if (!s) return s;
  }
  return Status::ok();
}

Ktx2Transcoded transcode_ktx2_images(const std::vector<Image*>& images,
                                     const Ktx2TranscodeOptions& options) {
  Ktx2Transcoded result;
  std::vector<Ktx2Decoded>& out = result.images;
  out.resize(images.size());
  // Headers first: what is malformed or too large fails here, by name, without a child.
  std::vector<Ktx2Header> headers(images.size());
  std::vector<size_t> sent;  // indices into `images` of those the child transcodes
  uint64_t input_bytes = 0, largest_rgba = 0;
  for (size_t i = 0; i < images.size(); ++i) {
    Image& image = *images[i];
    image.rgba.clear();
    image.width = image.height = 0;
    auto h = read_ktx2_header(image.encoded);
    if (!h.ok()) {
      out[i].status = bad(image.name + ": KTX2: " + h.status().message());
      continue;
    }
    const uint64_t pixels = uint64_t(h->width) * uint64_t(h->height);
    if (pixels > options.max_pixels) {
      out[i].over_limit = true;
      out[i].status = bad(image.name + ": image is " + std::to_string(h->width) + "x" +
                          std::to_string(h->height) + ", over the limit of " +
                          std::to_string(options.max_pixels) + " pixels");
      continue;
    }
    headers[i] = *h;
    sent.push_back(i);
    input_bytes += image.encoded.size();
    largest_rgba = std::max(largest_rgba, pixels * 4);
  }
  if (sent.empty()) return result;
  auto fail_all = [&](const Status& why) {
    result.run = why;
    for (size_t i : sent) {
      out[i].status = Status::error(images[i]->name + ": " + why.message(), why.kind());
      out[i].run_failed = true;
    }
    return result;
  };
  const char* env_node = std::getenv("MESHMUX_NODE");
  const std::string node = env_node && *env_node ? env_node : options.node;
  if (find_program(node).empty())
    return fail_all(Status::error(
        "KTX2 textures are transcoded by Node.js, and '" + node +
            "' was not found: install Node.js 18 or later (Debian: apt-get install nodejs) "
            "or name it with MESHMUX_NODE",
        ErrorKind::kUnavailable));
  auto dir = ScratchDir::create("ktx2");
  if (!dir.ok()) return fail_all(dir.status());
  if (Status s = write_ktx2_transcoder(dir->path()); !s) return fail_all(s);
  for (size_t k = 0; k < sent.size(); ++k) {
    Status s = write_file_atomic(dir->file(std::to_string(k) + ".ktx2"), images[sent[k]]->encoded);
    if (!s) return fail_all(s);
  }
  RunOptions run;
  run.timeout_seconds =
      options.timeout_seconds > 0 ? options.timeout_seconds : 60 + 5 * double(input_bytes) / 1e6;
  run.max_data_bytes = options.max_data_bytes > 0
                           ? options.max_data_bytes
                           : (uint64_t(1) << 30) + 2 * input_bytes + 4 * largest_rgba;
  run.max_output_bytes = 64 * 1024;
  auto r = run_command({node, dir->file("ktx2_transcoder.cjs"), dir->path(),
                        std::to_string(sent.size()), std::to_string(options.max_pixels)},
                       run);
  if (!r.ok()) return fail_all(r.status().with_prefix("KTX2 transcoder"));
  if (r->exit.code != 0) {
    const std::string why = last_output_line(r->output);
    return fail_all(Status::error("KTX2 transcoder (" + node + ") failed with " +
                                      r->exit.describe() + (why.empty() ? "" : ": " + why),
                                  ErrorKind::kInternal));
  }
  for (size_t k = 0; k < sent.size(); ++k)
    out[sent[k]] = take_answer(*dir, k, headers[sent[k]], *images[sent[k]]);
  return result;
}

}  // namespace meshmux
