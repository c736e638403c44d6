// The multiplexing order (Yang, Shen and Kuo, "Progressive coding of 3D textured graphic model
// via joint mesh-texture optimization" §3): mesh layers M₀…M_{m−1} (refinement batches) and
// texture layers T₀…T_{n−1} (texture levels) span a grid of states (i, j) whose rate is the
// bytes of M₀..Mᵢ plus T₀..Tⱼ as the stream holds them and whose distortion is measured by
// rendering. From (0, 0), the steepest descent repeatedly takes whichever of (i+1, j) and
// (i, j+1) lowers the distortion most per added byte, until (m−1, n−1). Distortions are
// evaluated lazily and cached, so only the cells the path visits and their neighbours are
// rendered. The three baselines of Yang, Shen and Kuo: mesh first, texture first, constant ratio.
#pragma once

#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

namespace meshmux {

struct RdGrid {
  std::vector<uint64_t> mesh_bytes;     // per mesh layer: its bytes in the stream (layer 0: base)
  std::vector<uint64_t> texture_bytes;  // per texture level: its bytes (level 0: the base level)
  // Expected distortion of state (i, j); called at most once per cell by a schedule.
  std::function<double(int i, int j)> distortion;
};

struct RdPath {
  std::vector<std::pair<int, int>> cells;  // visited states, (0,0) first, (m−1, n−1) last
  std::vector<uint64_t> bytes;             // cumulative stream bytes at each state
  std::vector<double> distortion;          // distortion at each state
};

// Caches a grid's distortion so several schedules share the renders; counts evaluations.
class RdCache {
 public:
  explicit RdCache(const RdGrid& grid);
  double at(int i, int j);
  size_t evaluated() const { return evaluated_; }
  int m() const { return int(grid_.mesh_bytes.size()); }
  int n() const { return int(grid_.texture_bytes.size()); }
  uint64_t bytes(int i, int j) const;  // cumulative bytes of state (i, j)

 private:
  const RdGrid& grid_;
  std::vector<double> value_;
  std::vector<char> known_;
  size_t evaluated_ = 0;
};

RdPath steepest_descent(RdCache& cache);
RdPath mesh_first(RdCache& cache);
RdPath texture_first(RdCache& cache);
// Keeps the ratio of mesh bytes to texture bytes as close as possible to that of the full
// stream, adding whichever layer keeps it closer.
RdPath constant_ratio(RdCache& cache);

// Area under the curve: distortion integrated over bytes (trapezoids), from the path's first to
// its last byte count. Paths from one grid share both ends, so areas compare.
double area_under(const RdPath& path);

}  // namespace meshmux
