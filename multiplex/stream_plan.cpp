// Stream steps and orders from the multiplexer's paths (see stream_plan.h). Every path of paper
// 004 walks the m × n grid from (0, 0) to (m−1, n−1) one layer at a time, so each path is an
// interleaving of the same moves: "mesh layer i arrives" and "texture level j arrives".
#include "multiplex/stream_plan.h"

#include <map>
#include <string>

namespace meshmux {

namespace {

Status bad(const std::string& what) {
  return Status::error("stream plan: " + what, ErrorKind::kInternal);
}

// The moves of a path as (kind, layer) keys: (0, i) mesh layer i, (1, j) texture level j.
Result<std::vector<std::pair<int, int>>> moves(const RdPath& path, const std::string& name, int m,
                                               int n) {
  if (path.cells.empty() || path.cells.front() != std::make_pair(0, 0))
    return bad(name + ": does not start at (0, 0)");
  if (path.cells.back() != std::make_pair(m - 1, n - 1))
    return bad(name + ": does not end at the full state");
  if (path.distortion.size() != path.cells.size()) return bad(name + ": distortion count");
  std::vector<std::pair<int, int>> out;
  for (size_t k = 1; k < path.cells.size(); ++k) {
    auto [i0, j0] = path.cells[k - 1];
    auto [i1, j1] = path.cells[k];
    if (i1 == i0 + 1 && j1 == j0)
      out.push_back({0, i1});
    else if (i1 == i0 && j1 == j0 + 1)
      out.push_back({1, j1});
    else
      return bad(name + ": move " + std::to_string(k) + " is not one layer");
  }
  return out;
}

}  // namespace

Result<StreamPlan> stream_plan(const MultiplexResult& r) {
  int m = int(r.mesh_bytes.size()), n = int(r.texture_bytes.size());
  if (m < 1 || n < 1 || r.layer_levels.size() != size_t(m)) return bad("no layers");
  auto rd = moves(r.rd, "rate-distortion", m, n);
  if (!rd.ok()) return rd.status();
  StreamPlan plan;
  plan.base_distortion = r.rd.distortion[0];
  std::map<std::pair<int, int>, uint32_t> step_of;
  for (size_t k = 0; k < rd->size(); ++k) {
    auto [kind, layer] = (*rd)[k];
    StreamStep st;
    if (kind == 0) {
      st.kind = StreamStep::kMesh;
      st.mesh_layer = size_t(layer);
    } else {
      st.kind = StreamStep::kTexture;
      st.texture_level = size_t(layer);
    }
    st.distortion = r.rd.distortion[k + 1];
    plan.steps.push_back(std::move(st));
    step_of[(*rd)[k]] = uint32_t(k);
  }
  const std::pair<const char*, const RdPath*> baselines[] = {{"mesh-first", &r.mesh_first},
                                                             {"texture-first", &r.texture_first},
                                                             {"constant-ratio", &r.constant_ratio}};
  for (const auto& [name, path] : baselines) {
    if (path->cells.empty()) continue;  // not computed
    auto mv = moves(*path, name, m, n);
    if (!mv.ok()) return mv.status();
    StreamOrder order;
    order.name = name;
    for (size_t k = 0; k < mv->size(); ++k) {
      auto it = step_of.find((*mv)[k]);
      if (it == step_of.end()) return bad(std::string(name) + ": a move the descent lacks");
      order.steps.push_back(it->second);
      order.distortion.push_back(path->distortion[k + 1]);
    }
    plan.orders.push_back(std::move(order));
  }
  return plan;
}

PackageView package_view(const MultiplexOptions& options) {
  const ViewOptions& v = options.views;
  const RenderOptions& r = options.render;
  PackageView p;
  p.fov_y_degrees = v.fov_y_degrees, p.fill = v.fill, p.clip_margin = v.clip_margin;
  p.direction[0] = v.direction.x, p.direction[1] = v.direction.y, p.direction[2] = v.direction.z;
  p.ambient = r.ambient, p.diffuse = r.diffuse;
  p.light_direction[0] = r.light_direction.x, p.light_direction[1] = r.light_direction.y;
  p.light_direction[2] = r.light_direction.z;
  p.light_follows_camera = r.light_follows_camera;
  p.physical = r.shading == Shading::kPhysical;
  p.environment = r.environment, p.light_intensity = r.light_intensity;
  if (options.display_width > 0 && options.display_height > 0)
    p.display[0] = options.display_width, p.display[1] = options.display_height;
  p.mse = options.metric == DistortionMetric::kMse;
  return p;
}

}  // namespace meshmux
