// The multiplexer's report (Yang, Shen and Kuo, "Progressive coding of 3D textured graphic
// model via joint mesh-texture optimization" §4 plots the same curves): report.json's curves,
// areas and summary, and rd.svg plotting them, beside the package as a viewer receives it and the
// plain download of model.glb. Pure functions of a MultiplexResult (and the package's real
// bytes); O(layers + steps).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "multiplex/multiplex.h"

namespace meshmux {

// The stream as a viewer receives it, beside the plain download of model.glb. Both show nothing
// (empty_distortion) until their first picture; the download's first picture is its last byte, and
// then it shows the full model (distortion 0).
struct DownloadComparison {
  uint64_t model_glb_bytes = 0;
  // The package as received: (bytes received, distortion shown from then on), from (0, empty):
  // the first picture once the header, table, base and base faces are in, then each chunk of
  // the stored order with its real size.
  std::vector<std::pair<uint64_t, double>> package;
};

// Area under a received-bytes / distortion step curve: each distortion holds until the next
// point's bytes have arrived (what a viewer shows while downloading). Lower is better.
double step_area(const std::vector<std::pair<uint64_t, double>>& curve);

// Costs the first state (the base: mesh layer 0 with texture level 0) with the bytes a viewer
// really receives before its first picture (`first_picture_bytes`: the package's header, table
// and base), instead of the multiplexer's estimate for layer 0: every path's cumulative bytes
// move by the same amount (so the order and every area are unchanged) and mesh_bytes[0] becomes
// those bytes less texture level 0's. Then report.json's and rd.svg's curves start where the
// package as received does.
void cost_base_as_shipped(MultiplexResult& r, uint64_t first_picture_bytes);

// report.json's "curves" and summary as JSON text, and rd.svg plotting the four curves; with
// `vs`, also the package as received against the download of model.glb ("download" curve,
// their step areas and whether the stream beats the file).
// What the output draws, for report.json's "output": the atlas's pages, width × height each
// (atlas/atlas.h AtlasReport::pages; empty without an atlas), and model.glb's draw calls
// (SceneStats::draw_calls: one per primitive per instance).
struct OutputFigures {
  std::vector<std::pair<int, int>> atlas_pages;
  uint64_t draw_calls = 0;
  std::string texture_encoder;  // the KTX2 encoder's version when the textures are KTX2, else ""
};
// With `output`, report.json also holds "output": {"atlas_pages": [[w, h], ...], "draw_calls": n}
// (and "texture_encoder": "..." when set).
std::string report_json(const MultiplexResult& r, const DownloadComparison* vs = nullptr,
                        const OutputFigures* output = nullptr);
std::string rd_svg(const MultiplexResult& r, const DownloadComparison* vs = nullptr);

}  // namespace meshmux
