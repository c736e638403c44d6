// Rate-distortion multiplexing, Yang, Shen and Kuo, "Progressive coding of 3D textured graphic
// model via joint mesh-texture optimization" §3 ("steepest descent over the distortion
// surface") and its three baselines.
#include "multiplex/schedule.h"

#include <cmath>
#include <limits>

namespace meshmux {

RdCache::RdCache(const RdGrid& grid) : grid_(grid) {
  value_.assign(size_t(m()) * size_t(n()), 0.0);
  known_.assign(value_.size(), 0);
}

double RdCache::at(int i, int j) {
  size_t k = size_t(i) * size_t(n()) + size_t(j);
  if (!known_[k]) {
    value_[k] = grid_.distortion(i, j);
    known_[k] = 1;
    ++evaluated_;
  }
  return value_[k];
}

uint64_t RdCache::bytes(int i, int j) const {
  uint64_t b = 0;
  for (int k = 0; k <= i; ++k) b += grid_.mesh_bytes[size_t(k)];
  // Texture levels are independent images: the stream carries every level up to j.
  for (int k = 0; k <= j; ++k) b += grid_.texture_bytes[size_t(k)];
  return b;
}

namespace {

void add(RdPath& p, RdCache& c, int i, int j) {
  p.cells.push_back({i, j});
  p.bytes.push_back(c.bytes(i, j));
  p.distortion.push_back(c.at(i, j));
}

}  // namespace

RdPath steepest_descent(RdCache& c) {
  RdPath p;
  int i = 0, j = 0;
  add(p, c, i, j);
  while (i < c.m() - 1 || j < c.n() - 1) {
    double here = c.at(i, j);
    double best = -std::numeric_limits<double>::infinity();
    int bi = i, bj = j;
    auto consider = [&](int ni, int nj) {
      double gain = (here - c.at(ni, nj)) / double(c.bytes(ni, nj) - c.bytes(i, j) + 1);
      // Ties: the mesh step first (deterministic).
      if (gain > best) best = gain, bi = ni, bj = nj;
    };
    if (i < c.m() - 1) consider(i + 1, j);
    if (j < c.n() - 1) consider(i, j + 1);
    i = bi, j = bj;
    add(p, c, i, j);
  }
  return p;
}

RdPath mesh_first(RdCache& c) {
  RdPath p;
  add(p, c, 0, 0);
  for (int i = 1; i < c.m(); ++i) add(p, c, i, 0);
  for (int j = 1; j < c.n(); ++j) add(p, c, c.m() - 1, j);
  return p;
}

RdPath texture_first(RdCache& c) {
  RdPath p;
  add(p, c, 0, 0);
  for (int j = 1; j < c.n(); ++j) add(p, c, 0, j);
  for (int i = 1; i < c.m(); ++i) add(p, c, i, c.n() - 1);
  return p;
}

RdPath constant_ratio(RdCache& c) {
  RdPath p;
  int i = 0, j = 0;
  add(p, c, 0, 0);
  uint64_t full = c.bytes(c.m() - 1, c.n() - 1);
  uint64_t mesh_full = c.bytes(c.m() - 1, 0) - c.bytes(0, 0);
  double target = full > 0 ? double(mesh_full) / double(full) : 0.5;
  while (i < c.m() - 1 || j < c.n() - 1) {
    auto ratio = [&](int a, int b) {
      uint64_t total = c.bytes(a, b);
      double mesh = double(c.bytes(a, 0) - c.bytes(0, 0));
      return total ? mesh / double(total) : 0.0;
    };
    bool can_m = i < c.m() - 1, can_t = j < c.n() - 1;
    bool take_mesh;
    if (can_m && can_t)
      take_mesh = std::abs(ratio(i + 1, j) - target) <= std::abs(ratio(i, j + 1) - target);
    else
      take_mesh = can_m;
    if (take_mesh)
      ++i;
    else
      ++j;
    add(p, c, i, j);
  }
  return p;
}

double area_under(const RdPath& p) {
  double a = 0;
  for (size_t k = 1; k < p.bytes.size(); ++k)
    a += 0.5 * (p.distortion[k] + p.distortion[k - 1]) * double(p.bytes[k] - p.bytes[k - 1]);
  return a;
}

}  // namespace meshmux
