// Instance-aware simplification (Azim, Cheslack-Postava and Levis, "Instance-aware
// simplification of 3D polygonal meshes") recorded as progressive meshes (Hoppe, "Octaviewer:
// spherically parameterized progressive meshes"), with the base level chosen by the stopping
// rule of Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion of 3D models
// for interactive metaverses" (§4.5, formula 1).
//
// What it does, per submesh (Scene Mesh), on the cleaned scene:
// - quadric error edge collapse restricted to half-edge collapses (a collapse moves position u
//   onto an existing neighbour v), with attribute terms for normals, uv and colour (Hoppe 1999
//   style: per-face linear attribute gradients folded into each vertex quadric), so uv seams
//   and hard edges are charged for what they lose;
// - topology is welded on position: the vertices (wedges) sharing a position collapse together,
//   each onto the matching wedge of the target, so flat-shaded input (a normal per face)
//   simplifies like smooth input and seams never crack;
// - boundary edges add a perpendicular constraint plane weighted by edge length²; border
//   vertices only slide along the border; collapses that flip a face, break the link condition
//   (manifoldness), or would leave the submesh with fewer than `min_submesh_triangles` are
//   refused;
// - instance-aware quadrics: a vertex's quadric is Σᵢ Tᵢᵀ Qᵢ Tᵢ over the submesh's instances,
//   evaluated in normalized scene units (scene diagonal = 1), so errors compare across
//   submeshes and the selection can hand triangles to where they are seen most;
// - a scene with fewer than `flatten_below_ips` instances per submesh is flattened into one
//   mesh (per material) and simplified as such (Azim et al.: IAS pays off above 1.75);
// - a submesh of more than `block_above` faces is first simplified as a hierarchy of blocks on
//   every core (Ponchio and Dellepiane, Nexus; Kapoulkine, clusterlod): spatial blocks with
//   locked borders, shifted between levels, each under a shared error bound, their collapses
//   merged by error into the one history; the whole-submesh loop finishes from there;
// - the whole collapse sequence is recorded: ProgressiveMesh levels from the coarsest reachable
//   mesh to the full one, with monotone errors, and an InstanceOrder per submesh for thinning.
// Complexity: O(T log T) per submesh (passes of sorted independent collapses, their costing on
// every core), plus O(T × instances) for the instance quadrics.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/progress.h"
#include "scene/progressive.h"
#include "scene/scene.h"

namespace meshmux {

struct SimplifyOptions {
  // Attribute weights turn attribute deviations into distances (fractions of the diagonal).
  // They trade shading and texture fidelity against geometric error; these defaults were
  // chosen on the shared models with bench/simplify (Hausdorff vs meshopt_simplify).
  float normal_weight = 0.005f;        // normals: a 30° error counts like 0.25% of the diagonal
  float uv_weight = 0.05f;             // texture coordinates: 2% of the texture ≈ 0.1%
  float color_weight = 0.05f;          // vertex colours (RGBA in [0,1])
  float boundary_weight = 1.0f;        // constraint-plane weight on open boundaries (× length²)
  double flatten_below_ips = 1.75;     // flatten when instances per submesh are below this
                                       // (clean/flatten.h should_flatten; the pipeline's
                                       // flattening after the atlas reads the same field)
  uint32_t min_submesh_triangles = 1;  // no collapse takes a submesh below this many triangles
  float stop_ratio = 0.9f;             // Terrace et al. formula 1 threshold for the base level
  float base_max_error = 0.005f;       // the base also stops when the cheapest collapse left
                                       // costs more than this (fraction of the diagonal)
  // Big meshes: a block hierarchy first (simplifier.h run_block_levels), on every core.
  uint64_t block_above = 1000000;    // a submesh with more faces takes the block levels first
  uint32_t block_positions = 32768;  // positions per block (about half its faces)
  uint64_t block_until = 262144;     // block levels run while more faces than this are live
  uint32_t merge_release_bytes = 65536;  // a level's merge hands back a block's lists' pages
                                         // every this many bytes of its collapses read (they
                                         // shrink as the merged history grows); 0: each list
                                         // held whole until its block is merged
  std::string spill_dir;  // the first block level's quadrics wait in an unnamed file here (the
                          // output's folder): ~75 bytes per input face out of memory; empty:
                          // they stay in memory
  uint64_t ship_whole_below = 10000;  // scenes under this many triangles ship whole (base = full)
  double ship_whole_fraction = 0.10;  // refinements under this fraction of the mesh: ship whole
  // The collapse loop's passes (bench/simplify.sh: at 1% and 1.1 the Hausdorff distances of
  // the shared models at 20% match a true greedy's, geometric mean 0.97 of its; at 5% and 1.5
  // the loop is 1.5x faster and up to 37% worse on some).
  float pass_fraction = 0.01f;     // triangles removed per pass, as a fraction of live ones
                                   // (smaller: closer to a true greedy order, more passes)
  float pass_error_growth = 1.1f;  // a pass stops at this times the error of its expected
                                   // last collapse (smaller: closer to greedy, more passes)
  float min_flip_cos = 0.25f;      // refuse collapses that turn a face by more than ~75°
};

struct SimplifyReport {
  bool flattened = false;  // the flatten path was taken
  double instances_per_submesh = 0;
  uint64_t input_triangles = 0;  // scene triangles (instances expanded)
  uint64_t collapses = 0;        // over all submeshes
  uint64_t spilled_bytes = 0;    // written to SimplifyOptions::spill_dir's file (all submeshes)
  uint64_t mapped_bytes = 0;     // the block levels' rest's quadrics, mapped from a file there
  uint32_t block_levels = 0;     // block levels run (the most over submeshes; 0: none)
  uint64_t refused_flip = 0, refused_link = 0, refused_wedge = 0, refused_vanish = 0;
  double seconds = 0;  // wall time of build_progressive
};

// Builds the progressive record of a cleaned scene (clean() first: welded, no degenerate
// faces, normalization_scale set). Deterministic.
// `progress` (optional) receives the fraction done: collapses so far over the positions of
// every submesh (the record collapses nearly all of them).
ProgressiveScene build_progressive(const Scene& cleaned, const SimplifyOptions& options,
                                   SimplifyReport* report = nullptr, Progress* progress = nullptr);

}  // namespace meshmux

namespace meshmux {

// The instance-aware quadric of one mesh-space face (Azim et al. equation 5 for one face):
// Σᵢ Tᵢᵀ Q(Tᵢ·face) Tᵢ, where Q is the area-weighted plane quadric of the placed face. Returned
// as a symmetric 4x4, row-major: vᵀ Q v (v = (x, y, z, 1)) is the summed squared distance of v's
// images to the placed planes, weighted by their areas. Used by build_progressive; exposed for
// tests and tools.
std::array<double, 16> instance_face_quadric(Vec3 a, Vec3 b, Vec3 c,
                                             const std::vector<Mat4>& transforms);

}  // namespace meshmux
