// The end of a batch: OUTROOT/batch.json and OUTROOT/index.html, listing every input of the
// batch (in list order) with its status, error line, time, bytes in and out and a link to its
// viewer, from the records the conversions left (batch/plan.h). An input without a record is
// listed as not converted, with the reason the caller knows (interrupted, a Slurm task that
// ended early), so nothing is lost from the summary.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "batch/plan.h"

namespace meshmux {

struct BatchSummaryInfo {
  std::string mode;                       // "local" or "slurm"
  std::vector<std::string> convert_args;  // the options every conversion had
  std::string fingerprint;                // their fingerprint (records with another: stale)
  double seconds = 0;                     // this run's wall time
  // Why an input has no record, by name (e.g. "Slurm task 3 ended FAILED, exit 1:0").
  std::map<std::string, std::string> missing_reason;
  std::string missing_default = "not converted (the batch was interrupted)";
  std::vector<std::string> skipped;  // names reused from an earlier run
  std::string slurm_json;            // Slurm's job array and task states (JSON), or ""
  std::string layout;                // a layout file for world.json (batch/world.h); "": grid
};

struct BatchCounts {
  size_t inputs = 0, ok = 0, with_warnings = 0, failed = 0, not_converted = 0, reused = 0;
  size_t world_packages = 0, world_placements = 0;  // in world.json
  std::vector<std::string> world_notes;  // streamed models left out of world.json, and why;
                                         // layout names no converted model has
};

// Writes batch.json, index.html and world.json into `outroot` (each atomically) and returns
// the counts. world.json holds every current conversion with a stream (its package, and the
// box report.json gives), on a grid or as info.layout places them (batch/world.h).
Result<BatchCounts> write_batch_summary(const std::string& outroot, const std::string& state_dir,
                                        const std::vector<BatchItem>& items,
                                        const BatchSummaryInfo& info);

}  // namespace meshmux
