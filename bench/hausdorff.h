// Symmetric Hausdorff distance between two scenes, for the simplification benchmark.
//
// Both scenes are taken in world space with every instance expanded. N points are sampled on
// each surface (area-weighted, deterministic: a fixed-seed generator of our own, so the same
// scenes give the same numbers on every machine); for each sample the exact distance to the
// nearest triangle of the other surface is found through a bounding-volume hierarchy over that
// surface's triangles. The directed distance A→B is the largest such distance over A's samples;
// the Hausdorff distance is the larger of A→B and B→A. Mean and RMS are over all 2N samples.
// Every distance is divided by the bounding-box diagonal of `reference` (the input scene).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "scene/scene.h"

namespace meshmux::bench {

struct HausdorffOptions {
  size_t samples = 100000;  // points sampled on each surface
  uint64_t seed = 0x5eed1234abcdULL;
};

struct HausdorffResult {
  double hausdorff = 0;  // max(forward, backward), relative to the reference diagonal
  double forward = 0;    // max over the reference's samples of the distance to `other`
  double backward = 0;   // max over `other`'s samples of the distance to the reference
  double mean = 0;       // mean of all 2N sample distances, relative
  double rms = 0;        // root mean square of all 2N sample distances, relative
  double diagonal = 0;   // the reference's bounding-box diagonal, author's units
  bool valid = false;    // false when either surface has no area
};

// World-space triangles of a scene, instances expanded: 9 floats per triangle.
std::vector<float> world_triangles(const Scene& scene);

HausdorffResult hausdorff(const Scene& reference, const Scene& other,
                          const HausdorffOptions& options = {});

// The same on triangle soups (9 floats per triangle), distances relative to `diagonal`.
HausdorffResult hausdorff_soup(const std::vector<float>& a, const std::vector<float>& b,
                               double diagonal, const HausdorffOptions& options = {});

// A reference surface prepared once, for comparing many others against it (the levels of one
// input): its samples and its search structure are built here and not again per comparison.
// compare(b) gives exactly hausdorff_soup(a, b, diagonal, options). The soup may be freed once
// this is built (the structure keeps its own copy).
class HausdorffReference {
 public:
  HausdorffReference(const std::vector<float>& soup, double diagonal,
                     const HausdorffOptions& options = {});
  ~HausdorffReference();
  HausdorffReference(HausdorffReference&&) noexcept;
  HausdorffReference& operator=(HausdorffReference&&) noexcept;

  HausdorffResult compare(const std::vector<float>& other) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace meshmux::bench
