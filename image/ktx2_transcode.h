// KTX2 textures (Basis Universal ETC1S or UASTC: glTF's KHR_texture_basisu) decoded to RGBA8
// for the atlas and every other stage that reads pixels. No Debian package has a Basis
// transcoder, so the one three.js ships (basis_transcoder.js + .wasm, Apache-2.0, the same the
// web client uses) runs under Node.js in a child process with a time and a data limit. The
// transcoder and the script that drives it (image/ktx2_transcoder.cjs) are embedded in the
// meshmux binary at build time and written into a private temporary folder for each run, so an
// installed meshmux needs nothing beside itself but `node` on PATH.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/status.h"
#include "scene/scene.h"

namespace meshmux {

// What a KTX2 file's header says (KTX 2.0 specification §3), checked against its size.
struct Ktx2Header {
  int width = 0, height = 0;      // level 0's pixels
  uint32_t levels = 1;            // mip levels in the file (levelCount, 0 read as 1)
  uint32_t supercompression = 0;  // 0 none, 1 BasisLZ, 2 Zstandard, 3 ZLIB
  bool etc1s = false;             // Basis ETC1S (BasisLZ); else UASTC
  bool srgb = false;              // the DFD's transfer function is sRGB
};

// Reads and checks the header of a Basis Universal KTX2 file: the identifier, the level index
// and the data format descriptor within the bytes, vkFormat 0 (Basis) with BasisLZ (ETC1S) or
// no / Zstandard supercompression (UASTC). Errors (kInput) say what is wrong in one phrase
// ("truncated header", "not a KTX2 file", "supercompression ZLIB, which the Basis transcoder does
// not read", ...), without a file name: the caller adds it. O(1).
Result<Ktx2Header> read_ktx2_header(const std::vector<uint8_t>& bytes);

struct Ktx2TranscodeOptions {
  std::string node = "node";  // the Node.js program (a name on PATH or a path); the
                              // MESHMUX_NODE environment variable, when set, replaces "node"
  uint64_t max_pixels = uint64_t(1) << 28;  // per image, checked on the header first
  double timeout_seconds = 0;               // for the whole run; 0: 60 s + 5 s per MB of KTX2 input
  uint64_t max_data_bytes = 0;  // the child's RLIMIT_DATA; 0: 1 GiB + 2 × the input bytes +
                                // 4 × the largest image's RGBA bytes
};

// One image's outcome.
struct Ktx2Decoded {
  Status status;            // ok, or why this image was not decoded (names the image)
  bool over_limit = false;  // the failure is only its size over max_pixels
  bool run_failed = false;  // the failure is the transcoder's run (Ktx2Transcoded::run), not
                            // this image's own
};

struct Ktx2Transcoded {
  std::vector<Ktx2Decoded> images;  // one per input image, in order
  Status run;  // ok, or why the transcoder could not run at all (no node: kUnavailable, naming
               // what to install; a crash, a kill, the time limit: kInternal): then every image
               // it was to transcode fails with this message prefixed by the image's name
};

// Decodes every image in `images` (their `encoded` KTX2 bytes) into rgba/width/height (level 0,
// RGBA8, row 0 at the top), in one child process for all of them. A damaged image fails alone
// (its name and the cause, from the header check or the transcoder) and the others decode.
// Never throws; the temporary folder is removed on every path. Time: ~0.2 s per 2048² image
// plus node's start (~0.1 s); memory: the images' RGBA.
Ktx2Transcoded transcode_ktx2_images(const std::vector<Image*>& images,
                                     const Ktx2TranscodeOptions& options = {});

// The files of the embedded transcoder (for the encoder's tests and tools): the script, three's
// basis_transcoder.js (to be saved as basis_transcoder.cjs) and basis_transcoder.wasm, written
// into `dir`. Errors (kOutput) name the file.
Status write_ktx2_transcoder(const std::string& dir);

}  // namespace meshmux
