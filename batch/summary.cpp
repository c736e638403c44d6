// batch.json and index.html of meshmux batch (see batch/summary.h).
#include "batch/summary.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>

#include "batch/world.h"
#include "core/file_io.h"
#include "core/text.h"
#include "exporters/viewer_page.h"
#include "stream/package.h"

#ifndef MESHMUX_VERSION
#error "MESHMUX_VERSION (the project version) must be defined: batch.json names it"
#endif

namespace meshmux {

namespace {

// Bytes for the page; empty for none.
std::string bytes_text(uint64_t b) { return b ? human_bytes(b) : ""; }

const char* kPageStyle =
    "body{font:14px/1.4 system-ui,sans-serif;margin:2em;color:#222}"
    "table{border-collapse:collapse;width:100%}th,td{padding:.3em .6em;text-align:left;"
    "border-bottom:1px solid #ddd;vertical-align:top}td.n{text-align:right;white-space:nowrap}"
    "th{background:#f4f4f4}.ok{color:#176c2c}.warn{color:#8a5a00}.fail{color:#b00020}"
    "code{font-size:12px}.err{font-family:monospace;font-size:12px;word-break:break-word}";

// The world box report.json gives a conversion ("bounds"), or why not.
Result<std::array<double, 6>> report_bounds(const std::string& outroot, const std::string& name) {
  auto bytes = read_whole_file(outroot + "/" + name + "/report.json", 64u << 20);
  if (!bytes.ok()) return bytes.status();
  auto j = nlohmann::json::parse(bytes->begin(), bytes->end(), nullptr, false);
  auto b = j.is_object() ? j.find("bounds") : j.end();
  if (!j.is_object() || b == j.end() || !b->is_array() || b->size() != 6)
    return Status::error(name + "/report.json: no \"bounds\" (converted by an older meshmux?)",
                         ErrorKind::kInput);
  std::array<double, 6> out{};
  for (size_t i = 0; i < 6; ++i) {
    // The world's own rule (stream/world_format.h): coordinates a float32 transform can place.
    if (!(*b)[i].is_number() || !std::isfinite((*b)[i].get<double>()) ||
        std::abs((*b)[i].get<double>()) > kWorldMaxCoordinate)
      return Status::error(
          name + "/report.json: \"bounds\" are not 6 coordinates a world can place",
          ErrorKind::kInput);
    out[i] = (*b)[i].get<double>();
  }
  return out;
}

// Where a package's base ends (header, table and base: what a client reads first), or 0 when
// that is unknown: a package past 64 MB is not read for it (its client then probes) and one
// that does not read is left to the client to report.
uint64_t package_head_bytes(const std::string& path) {
  auto bytes = read_whole_file(path, 64u << 20);
  if (!bytes.ok()) return 0;
  auto package = read_package(*bytes);
  return package.ok() ? package->base_offset + package->base_size : 0;
}

// world.json: the streamed conversions (`streamed`: name, package bytes), on a grid or where
// the layout file puts them. What is left out is said in counts.world_notes.
Status write_world(const std::string& outroot,
                   const std::vector<std::pair<std::string, uint64_t>>& streamed,
                   const std::string& layout_path, BatchCounts& counts) {
  std::vector<WorldPackage> packages;
  for (const auto& [name, bytes] : streamed) {
    auto bounds = report_bounds(outroot, name);
    if (!bounds.ok()) {
      counts.world_notes.push_back(bounds.status().message() + "; left out of world.json");
      continue;
    }
    packages.push_back({name, name + "/model.mmxp", *bounds, bytes,
                        package_head_bytes(outroot + "/" + name + "/model.mmxp")});
  }
  World world;
  if (layout_path.empty()) {
    world = grid_world(std::move(packages));
  } else {
    auto layout = read_layout(layout_path);
    if (!layout.ok()) return layout.status().with_prefix("batch");
    std::vector<std::string> missing;
    world = apply_layout(std::move(packages), *layout, &missing);
    for (const std::string& name : missing)
      counts.world_notes.push_back(base_name(layout_path) + ": \"" + name +
                                   "\" is no streamed model of this batch; not placed");
  }
  counts.world_packages = world.packages.size();
  counts.world_placements = world.placements.size();
  if (Status s = write_file_atomic(outroot + "/world.json", world_json(world)); !s) return s;
  // world.html and the library it runs on (MeshmuxWorld), beside world.json.
  return write_viewer(outroot, ViewerPage::kWorld);
}

}  // namespace

Result<BatchCounts> write_batch_summary(const std::string& outroot, const std::string& state_dir,
                                        const std::vector<BatchItem>& items,
                                        const BatchSummaryInfo& info) {
  BatchCounts counts;
  const std::set<std::string> reused(info.skipped.begin(), info.skipped.end());
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  // The page lists what needs attention first: failed, then with warnings, then the rest
  // (each in list order); batch.json keeps the list order.
  std::string rows_by_class[3];
  std::vector<std::pair<std::string, uint64_t>> streamed;  // (name, package bytes), list order
  for (const BatchItem& item : items) {
    ++counts.inputs;
    auto rec = read_record(state_dir, item.name);
    std::error_code ec;
    const bool current = rec && rec->hash == item.hash && rec->options == info.fingerprint &&
                         rec->input == item.input &&
                         (rec->status != "ok" || std::filesystem::is_regular_file(
                                                     outroot + "/" + item.name + "/model.glb", ec));
    nlohmann::ordered_json j;
    j["input"] = item.input;
    j["name"] = item.name;
    std::string status, error, cls;
    if (!current) {
      status = "not converted";
      auto it = info.missing_reason.find(item.name);
      error = it != info.missing_reason.end() ? it->second : info.missing_default;
      cls = "fail";
      ++counts.not_converted;
    } else if (rec->status == "ok") {
      status = rec->warnings ? "ok, with warnings" : "ok";
      cls = rec->warnings ? "warn" : "ok";
      ++counts.ok;
      if (rec->warnings) ++counts.with_warnings;
    } else {
      status = "failed";
      error = rec->error;
      cls = "fail";
      ++counts.failed;
    }
    const bool was_reused = current && reused.count(item.name);
    if (was_reused) ++counts.reused;
    j["status"] = status;
    j["error"] = error;
    j["cause"] = current ? rec->cause : "not run";
    j["warnings"] = current ? rec->warnings : 0;
    j["first_warning"] = current ? rec->first_warning : "";
    j["seconds"] = current ? std::round(rec->seconds * 100) / 100 : 0.0;
    j["bytes_in"] = item.bytes_in;
    j["glb_bytes"] = current ? rec->glb_bytes : 0;
    j["stream_bytes"] = current ? rec->stream_bytes : 0;
    const bool ok = current && rec->status == "ok";
    if (ok && rec->stream_bytes > 0) streamed.push_back({item.name, rec->stream_bytes});
    j["output"] = ok ? item.name + "/" : "";
    j["viewer"] = ok && rec->viewer ? item.name + "/index.html" : "";
    j["log"] = ".meshmux-batch/logs/" + item.name + ".log";
    j["reused"] = was_reused;
    j["worker"] = current ? rec->worker : "";
    list.push_back(j);

    // The page's row.
    std::string link = html_escape(item.name);
    if (ok)
      link = "<a href=\"" + url_escape(item.name) + (rec->viewer ? "/index.html" : "/model.glb") +
             "\">" + link + "</a>";
    std::string detail = error;
    if (ok && rec->warnings)
      detail = std::to_string(rec->warnings) + " warning" + (rec->warnings > 1 ? "s" : "") + ": " +
               rec->first_warning;
    char secs[32] = "";
    if (current) std::snprintf(secs, sizeof secs, "%.1f s", rec->seconds);
    rows_by_class[cls == "fail"   ? 0
                  : cls == "warn" ? 1
                                  : 2] +=
        "<tr><td>" + link + "<br><code>" + html_escape(item.input) + "</code></td><td class=\"" +
        cls + "\">" + html_escape(status) + (was_reused ? " (earlier run)" : "") +
        "</td><td class=\"err\">" + html_escape(detail) + "</td><td class=\"n\">" + secs +
        "</td><td class=\"n\">" + bytes_text(item.bytes_in) + "</td><td class=\"n\">" +
        (current ? bytes_text(rec->glb_bytes) : "") + "</td><td class=\"n\">" +
        (current ? bytes_text(rec->stream_bytes) : "") + "</td></tr>\n";
  }

  nlohmann::ordered_json doc;
  doc["meshmux"] = MESHMUX_VERSION;
  doc["outroot"] = outroot;
  doc["mode"] = info.mode;
  doc["convert_options"] = info.convert_args;
  doc["seconds"] = std::round(info.seconds * 100) / 100;
  doc["counts"] = {{"inputs", counts.inputs},
                   {"ok", counts.ok},
                   {"with_warnings", counts.with_warnings},
                   {"failed", counts.failed},
                   {"not_converted", counts.not_converted},
                   {"reused", counts.reused}};
  if (!info.slurm_json.empty())
    doc["slurm"] = nlohmann::ordered_json::parse(info.slurm_json, nullptr, false);
  doc["inputs"] = list;
  if (Status s = write_file_atomic(
          outroot + "/batch.json",
          doc.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
      !s)
    return s;

  char head[512];
  std::snprintf(head, sizeof head,
                "%zu inputs: <span class=\"ok\">%zu converted</span> (%zu with warnings, %zu "
                "from an earlier run), <span class=\"fail\">%zu failed, %zu not converted</span>",
                counts.inputs, counts.ok, counts.with_warnings, counts.reused, counts.failed,
                counts.not_converted);
  std::string page =
      "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
      "<meta name=\"viewport\" content=\"width=device-width,initial-scale=1\">"
      "<title>meshmux batch</title><style>" +
      std::string(kPageStyle) + "</style></head><body>\n<h1>meshmux batch</h1>\n<p>" + head +
      ". Each viewer streams its model over HTTP: <code>meshmux serve " + html_escape(outroot) +
      "</code>, then open the printed address. Every conversion's messages are in "
      "<code>.meshmux-batch/logs/</code>; the same list is in <a href=\"batch.json\">batch.json"
      "</a>. Every streamed model in one scene: <a href=\"world.html\">world.html</a> (<a "
      "href=\"world.json\">world.json</a>).</p>\n<table><thead><tr><th>input</th><th>status</"
      "th><th>error or warning</th>"
      "<th>time</th><th>bytes in</th><th>model.glb</th><th>stream</th></tr></thead><tbody>\n" +
      rows_by_class[0] + rows_by_class[1] + rows_by_class[2] + "</tbody></table>\n</body></html>\n";
  if (Status s = write_file_atomic(outroot + "/index.html", page); !s) return s;
  if (Status s = write_world(outroot, streamed, info.layout, counts); !s) return s;
  return counts;
}

}  // namespace meshmux
