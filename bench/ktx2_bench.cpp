// The KTX2 encoder's figures (image/ktx2_encode.h): for each image given, at 1024² and 2048²
// (cubic-resampled from it), ETC1S (sRGB) and UASTC (linear, Zstandard) encode time, bytes, and
// PSNR (RGB) of three's transcoder's level 0 against the encoder's input. A figure, not a test.
// usage: meshmux_bench_ktx2 [--threads N] [--uastc-level L] [--uastc-rdo LAMBDA]
//          [--etc1s-quality Q] [--etc1s-effort E] IMAGE...
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "image/decode.h"
#include "image/ktx2_encode.h"
#include "image/ktx2_transcode.h"
#include "image/psnr.h"
#include "image/resize.h"

using namespace meshmux;

int main(int argc, char** argv) {
  Ktx2EncodeOptions base;
  std::vector<std::string> files;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--threads" && i + 1 < argc)
      base.threads = std::atoi(argv[++i]);
    else if (a == "--uastc-level" && i + 1 < argc)
      base.uastc_level = std::atoi(argv[++i]);
    else if (a == "--uastc-rdo" && i + 1 < argc)
      base.uastc_rdo = std::atof(argv[++i]);
    else if (a == "--etc1s-quality" && i + 1 < argc)
      base.etc1s_quality = std::atoi(argv[++i]);
    else if (a == "--etc1s-effort" && i + 1 < argc)
      base.etc1s_effort = std::atoi(argv[++i]);
    else
      files.push_back(a);
  }
  auto version = ktx2_encoder_version(base);
  if (!version.ok()) {
    std::fprintf(stderr, "%s\n", version.status().message().c_str());
    return 77;
  }
  std::printf("encoder: %s, threads %d (0: all), ETC1S -q %d, UASTC level %d, RDO %.2f\n",
              version->c_str(), base.threads, base.etc1s_quality, base.uastc_level, base.uastc_rdo);
  std::printf(
      "| image | sides | mode | encode s | KTX2 bytes | PSNR dB |\n|---|---|---|---:|---:|---:|\n");
  for (const std::string& f : files) {
    auto loaded = load_image_file(f);
    if (!loaded.ok()) {
      std::fprintf(stderr, "%s\n", loaded.status().message().c_str());
      return 1;
    }
    for (int side : {1024, 2048}) {
      for (Ktx2Mode mode : {Ktx2Mode::kEtc1s, Ktx2Mode::kUastc}) {
        Ktx2EncodeOptions o = base;
        o.mode = mode;
        o.srgb = mode == Ktx2Mode::kEtc1s;
        const Image in = resize_cubic(*loaded, side, side, o.srgb);
        const auto start = std::chrono::steady_clock::now();
        auto e = encode_ktx2(in, o);
        const double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (!e.ok()) {
          std::fprintf(stderr, "%s\n", e.status().message().c_str());
          return 1;
        }
        Image back;
        back.name = f;
        back.encoded = e->bytes;
        Ktx2Transcoded t = transcode_ktx2_images({&back});
        const double db = t.images[0].status.is_ok() ? psnr_rgb(in, back) : -1;
        const char* slash = std::strrchr(f.c_str(), '/');
        std::printf("| %s | %d² | %s | %.2f | %zu | %.1f |\n", slash ? slash + 1 : f.c_str(), side,
                    mode == Ktx2Mode::kEtc1s ? "ETC1S" : "UASTC", seconds, e->bytes.size(), db);
        std::fflush(stdout);
      }
    }
  }
  return 0;
}
