#include "pipeline/outputs.h"

#include <cstdint>
#include <utility>
#include <vector>

#include "core/file_io.h"
#include "core/output_transaction.h"
#include "core/text.h"
#include "exporters/viewer_page.h"

namespace meshmux {

Status write_outputs(const std::string& out, bool folder, const ConvertOutputs& r,
                     Progress& progress) {
  if (!folder) return write_file_atomic(out, r.model_glb);
  auto txn = OutputFolder::begin(out);
  if (!txn.ok()) return txn.status();
  const std::string& dir = txn->dir();
  const std::pair<const char*, const std::vector<uint8_t>*> files[] = {
      {"model.glb", &r.model_glb}, {"base.glb", &r.base_glb}, {"model.mmxp", &r.package}};
  std::vector<std::string> written;
  for (const auto& [name, bytes] : files) {
    if (bytes->empty()) continue;
    if (Status s = write_file_atomic(dir + "/" + name, *bytes); !s) return s;
    written.push_back(out + "/" + name + " (" + human_bytes(bytes->size()) + ")");
  }
  if (!r.report_json.empty()) {
    if (Status s = write_file_atomic(dir + "/report.json", r.report_json); !s) return s;
    if (Status s = write_file_atomic(dir + "/rd.svg", r.rd_svg); !s) return s;
    written.push_back(out + "/report.json and " + out + "/rd.svg");
  }
  if (!r.package.empty()) {
    if (Status s = write_viewer(dir); !s) return s;
    written.push_back(out + "/index.html and " + out + "/viewer/ (meshmux serve " + out + ")");
  }
  if (Status s = txn->commit(); !s) return s;
  for (const std::string& w : written) progress.step("wrote " + w);
  return Status::ok();
}

}  // namespace meshmux
