// Writing a conversion's outputs: OUT.glb alone, or the folder's files (model.glb, base.glb,
// model.mmxp, report.json, rd.svg, the viewer), as one transaction.
#pragma once

#include <string>

#include "core/progress.h"
#include "core/status.h"
#include "pipeline/convert.h"

namespace meshmux {

// With `folder` false, writes r.model_glb to `out` atomically. Otherwise the folder is one
// transaction (core/output_transaction.h): written into a temporary folder beside `out` and
// swapped in when complete, so a failure leaves the previous output and nothing of a previous
// conversion survives beside the new one. Each file written is a progress step ("wrote ...").
// Errors (kOutput): the files or the folder could not be written.
Status write_outputs(const std::string& out, bool folder, const ConvertOutputs& r,
                     Progress& progress);

}  // namespace meshmux
