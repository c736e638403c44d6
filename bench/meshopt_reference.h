// meshoptimizer's meshopt_simplify as the benchmarks' reference simplifier (a global simplifier
// we did not write), run on a flattened scene (clean/flatten.h: instances expanded into world
// space, one primitive per material and vertex layout). Shared by meshmux_bench_simplify and
// meshmux_bench_scale.
#pragma once

#include <cstdint>

#include "scene/scene.h"

namespace meshmux::bench {

struct MeshoptRun {
  Scene scene;         // flattened, simplified, compacted
  double seconds = 0;  // meshopt_simplify calls only
  uint64_t triangles = 0;
  double ratio = 0;  // the per-primitive ratio asked for
};

uint64_t scene_tris(const Scene& s);

// Keeps only the vertices `indices` use, in order of first use.
void compact(Primitive& p);

// Welds every primitive's vertices on position alone (uv seams, hard edges and colour
// boundaries are dropped; the first vertex of each position keeps its attributes).
Scene weld_positions(const Scene& in);

// meshopt_simplify on every primitive of a flattened scene, to `ratio` of its indices,
// target_error 1.0 (the count decides).
MeshoptRun meshopt_run(const Scene& flat, double ratio);

// meshopt_simplify to (about) `target` scene triangles: the per-primitive ratio is corrected
// a few times by target / reached, keeping the run closest to the target. Its `seconds` are
// that run's alone.
MeshoptRun meshopt_to_count(const Scene& flat, uint64_t target);

}  // namespace meshmux::bench
