// The web viewer written beside a converted model (docs/ARCHITECTURE.md "What meshmux does"):
// index.html, the three.js client (viewers/web) and the parts of three.js it imports, so that
// `meshmux serve OUTDIR` (or any static web server) shows the stream at OUTDIR/index.html with no
// network access beyond OUTDIR. The files are built into the program (see viewer_page.cpp).
#pragma once

#include <string>
#include <vector>

#include "core/status.h"

namespace meshmux {

struct ViewerFile {
  std::string path;  // relative to the output folder, '/'-separated
  const char* data = nullptr;
  size_t size = 0;
};

// Every file of the viewer, in a fixed order.
std::vector<ViewerFile> viewer_files();

// Which page goes with the viewer files: a converted model's index.html, or the world.html of
// a batch's output root (MeshmuxWorld over its world.json).
enum class ViewerPage { kModel, kWorld };

// Writes viewer_files() under `dir` (creating viewer/ subfolders) with the page asked for and
// not the other, each through a temporary name renamed when complete; a file already there
// with the same bytes is left alone. Errors name the file (kOutput).
Status write_viewer(const std::string& dir, ViewerPage page = ViewerPage::kModel);

}  // namespace meshmux
