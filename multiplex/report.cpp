// The multiplexer's report (multiplex/report.h): report.json and rd.svg.
#include "multiplex/report.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <sstream>

#include "stream/mesh_stream.h"

namespace meshmux {

void cost_base_as_shipped(MultiplexResult& r, uint64_t first_picture_bytes) {
  if (r.rd.bytes.empty() || r.mesh_bytes.empty()) return;
  const uint64_t was = r.rd.bytes.front();
  for (RdPath* p : {&r.rd, &r.mesh_first, &r.texture_first, &r.constant_ratio})
    for (uint64_t& b : p->bytes) b = b - was + first_picture_bytes;
  const uint64_t texture0 = r.texture_bytes.empty() ? 0 : r.texture_bytes.front();
  r.mesh_bytes.front() = first_picture_bytes - std::min(first_picture_bytes, texture0);
}

namespace {

void curve(std::ostringstream& out, const RdPath& p) {
  out << "[";
  for (size_t k = 0; k < p.bytes.size(); ++k) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%s[%llu, %.6g]", k ? ", " : "",
                  static_cast<unsigned long long>(p.bytes[k]), p.distortion[k]);
    out << buf;
  }
  out << "]";
}

}  // namespace

double step_area(const std::vector<std::pair<uint64_t, double>>& curve) {
  double a = 0;
  for (size_t k = 1; k < curve.size(); ++k)
    a +=
        curve[k - 1].second * double(curve[k].first - std::min(curve[k].first, curve[k - 1].first));
  return a;
}

namespace {

// The download of model.glb as a step curve: nothing until its last byte, then the model.
std::vector<std::pair<uint64_t, double>> download_curve(const MultiplexResult& r,
                                                        const DownloadComparison& vs) {
  return {{0, r.empty_distortion}, {vs.model_glb_bytes, 0.0}};
}

void points(std::ostringstream& out, const std::vector<std::pair<uint64_t, double>>& c) {
  out << "[";
  for (size_t k = 0; k < c.size(); ++k) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%s[%llu, %.6g]", k ? ", " : "",
                  static_cast<unsigned long long>(c[k].first), c[k].second);
    out << buf;
  }
  out << "]";
}

}  // namespace

// Where the mesh stream's bits go (report.json "mesh_stream_bits"): the splits (vertices
// added) and new faces over every part, the parts' bytes in bits, and per StreamField the
// information its decisions carried (EncodedMeshPart::field_bits; the rest is the coder's
// flush and rounding).
namespace {
std::string mesh_stream_bits_json(const std::vector<std::vector<EncodedMeshPart>>& layers) {
  uint64_t splits = 0, faces = 0, bits = 0;
  std::array<double, kStreamFields> fields{};
  for (const auto& layer : layers)
    for (const EncodedMeshPart& p : layer) {
      splits += p.part.vertex_end - p.part.vertex_begin;
      faces += p.part.face_end - p.part.face_begin;
      bits += 8 * p.bytes();
      for (size_t f = 0; f < kStreamFields; ++f) fields[f] += p.field_bits[f];
    }
  std::ostringstream out;
  out << "{\"splits\": " << splits << ", \"faces\": " << faces << ", \"bits\": " << bits
      << ", \"fields\": {";
  char buf[64];
  for (size_t f = 0; f < kStreamFields; ++f) {
    std::snprintf(buf, sizeof buf, "%s\"%s\": %.0f", f ? ", " : "", kStreamFieldNames[f],
                  fields[f]);
    out << buf;
  }
  out << "}}";
  return out.str();
}
}  // namespace

std::string report_json(const MultiplexResult& r, const DownloadComparison* vs,
                        const OutputFigures* output) {
  std::ostringstream out;
  out << "{\n  \"curves\": {\n    \"rd\": ";
  curve(out, r.rd);
  out << ",\n    \"mesh_first\": ";
  curve(out, r.mesh_first);
  out << ",\n    \"texture_first\": ";
  curve(out, r.texture_first);
  out << ",\n    \"constant_ratio\": ";
  curve(out, r.constant_ratio);
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "\n  },\n  \"areas\": {\"rd\": %.6g, \"mesh_first\": %.6g, \"texture_first\": "
                "%.6g, \"constant_ratio\": %.6g},"
                "\n  \"distortion_metric\": \"%s\",\n  \"views\": %zu,\n  \"renders\": %zu,"
                "\n  \"cells_descent\": %zu,\n  \"cells_evaluated\": %zu,\n  \"cells_total\": %zu,",
                area_under(r.rd), area_under(r.mesh_first), area_under(r.texture_first),
                area_under(r.constant_ratio), r.metric.c_str(), r.views, r.renders, r.cells_descent,
                r.cells_evaluated, r.cells_total);
  out << buf;
  std::snprintf(buf, sizeof buf, "\n  \"empty_distortion\": %.6g,", r.empty_distortion);
  out << buf;
  // Renders on a cut (MultiplexOptions::cut_renders_above): the error a display pixel stands
  // for and the finest selection's triangles drawn (error 0: the full detail).
  std::snprintf(buf, sizeof buf, "\n  \"render_cut\": {\"error\": %.6g, \"triangles\": %llu},",
                r.cut_error, (unsigned long long)r.cut_triangles);
  out << buf;
  if (!r.bounds.empty()) {
    std::snprintf(buf, sizeof buf, "\n  \"bounds\": [%.9g, %.9g, %.9g, %.9g, %.9g, %.9g],",
                  r.bounds.min.x, r.bounds.min.y, r.bounds.min.z, r.bounds.max.x, r.bounds.max.y,
                  r.bounds.max.z);
    out << buf;
  }
  if (vs) {
    // The package as received against the plain download, areas over the same bytes axis
    // (each curve held at its last value up to the longer one's end).
    auto package = vs->package;
    auto download = download_curve(r, *vs);
    const uint64_t end = std::max(package.back().first, download.back().first);
    package.push_back({end, package.back().second});
    download.push_back({end, download.back().second});
    const double pa = step_area(package), da = step_area(download);
    out << "\n  \"download\": {\n    \"model_glb_bytes\": " << vs->model_glb_bytes
        << ",\n    \"package_bytes\": " << vs->package.back().first << ",\n    \"package_curve\": ";
    points(out, vs->package);
    out << ",\n    \"download_curve\": ";
    points(out, download_curve(r, *vs));
    std::snprintf(buf, sizeof buf,
                  ",\n    \"package_area\": %.6g,\n    \"download_area\": %.6g,"
                  "\n    \"stream_beats_download\": %s\n  },",
                  pa, da, pa < da ? "true" : "false");
    out << buf;
  }
  {
    // Where the chain of splits ended in the full mesh single-rate, and what that cost: the
    // descent's area with it against the descent over every split (the same views).
    const CompletionReport& c = r.completion_report;
    std::snprintf(buf, sizeof buf,
                  "\n  \"completion\": {\"used\": %s, \"why\": \"%s\", \"after_layer\": %zu, "
                  "\"chain_layers\": %zu, \"bytes\": %llu, \"tail_bytes\": %llu, "
                  "\"planned_bytes\": %llu, \"chain_bytes\": %llu, \"area\": %.6g, "
                  "\"chain_area\": %.6g, \"area_cost\": %.6g},",
                  c.used ? "true" : "false", c.why.c_str(), c.after_layer, c.chain_layers,
                  (unsigned long long)c.bytes, (unsigned long long)c.tail_bytes,
                  (unsigned long long)c.planned_bytes, (unsigned long long)c.chain_bytes, c.area,
                  c.chain_area, c.used ? c.area - c.chain_area : 0.0);
    out << buf;
  }
  out << "\n  \"mesh_layer_bytes\": [";
  for (size_t k = 0; k < r.mesh_bytes.size(); ++k) out << (k ? ", " : "") << r.mesh_bytes[k];
  out << "],\n  \"mesh_layer_triangles\": [";
  for (size_t k = 0; k < r.layer_triangles.size(); ++k)
    out << (k ? ", " : "") << r.layer_triangles[k];
  out << "],\n  \"stream_digests\": [";
  for (size_t k = 0; k < r.stream_digests.size(); ++k)
    out << (k ? ", " : "") << r.stream_digests[k];
  out << "],\n  \"mesh_stream_bits\": " << mesh_stream_bits_json(r.layer_parts);
  // A block hierarchy's parts (stream/format.h "Blocks"): per block part, the mesh layer that
  // ships it, its coded bytes, its level, the error it removes and how many blocks it needs.
  // (The order's distortion is measured per mesh layer, not per block.)
  bool blocks = false;
  for (const MeshStreamBase& m : r.mesh_streams) blocks = blocks || !m.blocks.empty();
  if (blocks) {
    out << ",\n  \"blocks\": [";
    bool first = true;
    for (size_t k = 0; k < r.layer_parts.size(); ++k)
      for (const EncodedMeshPart& part : r.layer_parts[k]) {
        if (part.part.block < 0 || part.part.mesh >= r.mesh_streams.size()) continue;
        const std::vector<StreamBlock>& list = r.mesh_streams[part.part.mesh].blocks;
        if (size_t(part.part.block) >= list.size()) continue;
        const StreamBlock& b = list[size_t(part.part.block)];
        std::snprintf(buf, sizeof buf,
                      "%s\n    {\"mesh\": %u, \"block\": %d, \"layer\": %zu, \"bytes\": %llu, "
                      "\"level\": %u, \"error\": %.6g, \"deps\": %zu}",
                      first ? "" : ",", part.part.mesh, part.part.block, k,
                      (unsigned long long)part.bytes(), b.level, b.error, b.deps.size());
        out << buf;
        first = false;
      }
    out << "\n  ]";
  }
  out << ",\n  \"texture_level_bytes\": [";
  for (size_t k = 0; k < r.texture_bytes.size(); ++k) out << (k ? ", " : "") << r.texture_bytes[k];
  out << "],\n  \"texture_levels\": {\"shipped\": [";
  for (size_t k = 0; k < r.texture_levels_shipped.size(); ++k) {
    const auto& l = r.texture_levels_shipped[k];
    out << (k ? ", " : "") << "{\"width\": " << l[0] << ", \"height\": " << l[1]
        << ", \"bytes\": " << l[2] << "}";
  }
  out << "], \"dropped\": [";
  for (size_t k = 0; k < r.texture_levels_dropped.size(); ++k) {
    const DroppedTextureLevel& l = r.texture_levels_dropped[k];
    out << (k ? ", " : "") << "{\"width\": " << l.width << ", \"height\": " << l.height
        << ", \"bytes\": " << l.bytes << ", \"why\": \"" << l.why << "\"}";
  }
  out << "], \"channels\": [";
  for (size_t k = 0; k < r.texture_channels.size(); ++k)
    out << (k ? ", " : "") << "\"" << r.texture_channels[k] << "\"";
  out << "], \"channels_move\": \"together\", \"channels_why\": \"each level carries every "
         "channel at its size, so the shading never mixes a base colour and a normal map of "
         "different resolutions; one step per level keeps the descent's grid one texture axis\"";
  out << "},\n  \"order\": [";
  for (size_t k = 0; k < r.rd.cells.size(); ++k)
    out << (k ? ", " : "") << "[" << r.rd.cells[k].first << ", " << r.rd.cells[k].second << "]";
  out << "]";
  if (output) {
    out << ",\n  \"output\": {\"atlas_pages\": [";
    for (size_t k = 0; k < output->atlas_pages.size(); ++k)
      out << (k ? ", " : "") << "[" << output->atlas_pages[k].first << ", "
          << output->atlas_pages[k].second << "]";
    out << "], \"draw_calls\": " << output->draw_calls;
    if (!output->texture_encoder.empty()) {
      std::string text;  // a JSON string: quotes and backslashes escaped, controls dropped
      for (char c : output->texture_encoder)
        if (c == '"' || c == '\\')
          text += '\\', text += c;
        else if (static_cast<unsigned char>(c) >= 0x20)
          text += c;
      out << ", \"texture_encoder\": \"" << text << "\"";
    }
    out << "}";
  }
  std::snprintf(buf, sizeof buf,
                ",\n  \"seconds\": {\"layers\": %.3f, \"render\": %.3f, \"total\": %.3f}\n}\n",
                r.seconds_layers, r.seconds_render, r.seconds_total);
  out << buf;
  return out.str();
}

std::string rd_svg(const MultiplexResult& r, const DownloadComparison* vs) {
  const int W = 640, H = 400, L = 60, R = 20, T = 20, B = 50;
  const RdPath* paths[4] = {&r.rd, &r.mesh_first, &r.texture_first, &r.constant_ratio};
  const char* names[4] = {"steepest descent", "mesh first", "texture first", "constant ratio"};
  const char* colors[4] = {"#d62728", "#1f77b4", "#2ca02c", "#9467bd"};
  double max_b = 1, max_d = 1e-9;
  for (const RdPath* p : paths)
    for (size_t k = 0; k < p->bytes.size(); ++k)
      max_b = std::max(max_b, double(p->bytes[k])), max_d = std::max(max_d, p->distortion[k]);
  // With the download comparison: the package as received and model.glb's download, as steps.
  std::vector<std::pair<uint64_t, double>> steps[2];
  if (vs) {
    steps[0] = vs->package;
    steps[1] = download_curve(r, *vs);
    for (const auto& c : steps)
      for (const auto& [b, d] : c) max_b = std::max(max_b, double(b)), max_d = std::max(max_d, d);
  }
  std::ostringstream out;
  out << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << H
      << "\" font-family=\"sans-serif\" font-size=\"12\">\n";
  out << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  out << "<line x1=\"" << L << "\" y1=\"" << H - B << "\" x2=\"" << W - R << "\" y2=\"" << H - B
      << "\" stroke=\"black\"/>\n";
  out << "<line x1=\"" << L << "\" y1=\"" << T << "\" x2=\"" << L << "\" y2=\"" << H - B
      << "\" stroke=\"black\"/>\n";
  char buf[256];
  std::snprintf(
      buf, sizeof buf,
      "<text x=\"%d\" y=\"%d\" text-anchor=\"middle\">stream bytes (0 … %.0f kB)</text>\n",
      (L + W - R) / 2, H - 15, max_b / 1000);
  out << buf;
  std::snprintf(buf, sizeof buf,
                "<text x=\"15\" y=\"%d\" transform=\"rotate(-90 15 %d)\" text-anchor=\"middle\">%s "
                "(0 … %.2f)</text>\n",
                (T + H - B) / 2, (T + H - B) / 2, r.metric.c_str(), max_d);
  out << buf;
  for (int c = 0; c < 4; ++c) {
    out << "<polyline fill=\"none\" stroke=\"" << colors[c] << "\" stroke-width=\""
        << (c == 0 ? 2.5 : 1.5) << "\" points=\"";
    for (size_t k = 0; k < paths[c]->bytes.size(); ++k) {
      double x = L + (W - L - R) * double(paths[c]->bytes[k]) / max_b;
      double y = (H - B) - (H - B - T) * paths[c]->distortion[k] / max_d;
      std::snprintf(buf, sizeof buf, "%.1f,%.1f ", x, y);
      out << buf;
    }
    out << "\"/>\n";
    std::snprintf(buf, sizeof buf, "<text x=\"%d\" y=\"%d\" fill=\"%s\">%s: area %.3g</text>\n",
                  W - R - 220, T + 15 + 16 * c, colors[c], names[c], area_under(*paths[c]));
    out << buf;
  }
  const char* step_names[2] = {"package as received", "model.glb download"};
  const char* step_colors[2] = {"#000000", "#ff7f0e"};
  for (int c = 0; c < 2 && vs; ++c) {
    out << "<polyline fill=\"none\" stroke=\"" << step_colors[c] << "\" stroke-width=\"1.5\""
        << (c == 0 ? " stroke-dasharray=\"4 3\"" : "") << " points=\"";
    for (size_t k = 0; k < steps[c].size(); ++k) {
      const double x = L + (W - L - R) * double(steps[c][k].first) / max_b;
      auto y = [&](double d) { return (H - B) - (H - B - T) * d / max_d; };
      if (k > 0) {
        std::snprintf(buf, sizeof buf, "%.1f,%.1f ", x, y(steps[c][k - 1].second));
        out << buf;
      }
      std::snprintf(buf, sizeof buf, "%.1f,%.1f ", x, y(steps[c][k].second));
      out << buf;
    }
    out << "\"/>\n";
    std::snprintf(buf, sizeof buf, "<text x=\"%d\" y=\"%d\" fill=\"%s\">%s: area %.3g</text>\n",
                  W - R - 220, T + 15 + 16 * (4 + c), step_colors[c], step_names[c],
                  step_area(steps[c]));
    out << buf;
  }
  out << "</svg>\n";
  return out.str();
}

}  // namespace meshmux
