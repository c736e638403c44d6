// meshmux batch on Slurm: plan, job array, dependent summary job (see batch/slurm.h).
#include "batch/slurm.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "core/process.h"
#include "batch/summary.h"
#include "core/exit_codes.h"
#include "core/file_io.h"

namespace meshmux {

namespace fs = std::filesystem;

namespace {

std::string plan_file(const std::string& state_dir) { return state_dir + "/plan.json"; }

// sbatch expands %-patterns in --output (%a the task, %u the user...): a literal '%' is "%%".
std::string sbatch_path(const std::string& path) {
  std::string out;
  for (char c : path) out += c == '%' ? std::string("%%") : std::string(1, c);
  return out;
}

// Single quotes for /bin/sh.
std::string sh_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

struct Plan {
  BatchOptions options;
  std::vector<BatchItem> items;     // every input, list order
  std::vector<size_t> todo;         // indices into items, in the order tasks take them
  std::vector<std::string> reused;  // names kept from an earlier run
  int tasks = 1;
  double started = 0;  // seconds since the epoch, at submission
};

Status write_plan(const Plan& p) {
  nlohmann::ordered_json j;
  j["outroot"] = p.options.outroot;
  j["state_dir"] = p.options.state_dir;
  j["exe"] = p.options.exe;
  j["convert_args"] = p.options.convert_args;
  j["fingerprint"] = p.options.fingerprint;
  j["timeout_seconds"] = p.options.timeout_seconds;
  j["max_memory_mb"] = p.options.max_memory_mb;
  j["retry_failed"] = p.options.retry_failed;
  j["layout"] = p.options.layout;
  j["jobs_per_task"] = p.options.jobs;
  j["tasks"] = p.tasks;
  j["started"] = p.started;
  nlohmann::ordered_json items = nlohmann::ordered_json::array();
  for (const BatchItem& it : p.items)
    items.push_back(
        {{"input", it.input}, {"name", it.name}, {"hash", it.hash}, {"bytes_in", it.bytes_in}});
  j["items"] = items;
  j["todo"] = p.todo;
  j["reused"] = p.reused;
  return write_file_atomic(plan_file(p.options.state_dir),
                           j.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

Result<Plan> read_plan(const std::string& path) {
  auto text = read_whole_file(path, uint64_t(512) << 20);
  if (!text.ok()) return text.status().with_prefix("batch");
  auto j = nlohmann::json::parse(text->begin(), text->end(), nullptr, false);
  Plan p;
  try {
    p.options.outroot = j.at("outroot").get<std::string>();
    p.options.state_dir = j.at("state_dir").get<std::string>();
    p.options.exe = j.at("exe").get<std::string>();
    p.options.convert_args = j.at("convert_args").get<std::vector<std::string>>();
    p.options.fingerprint = j.at("fingerprint").get<std::string>();
    p.options.timeout_seconds = j.at("timeout_seconds").get<double>();
    p.options.max_memory_mb = j.at("max_memory_mb").get<uint64_t>();
    p.options.retry_failed = j.at("retry_failed").get<bool>();
    p.options.layout = j.value("layout", std::string());
    p.options.jobs = j.at("jobs_per_task").get<int>();
    p.tasks = j.at("tasks").get<int>();
    p.started = j.at("started").get<double>();
    for (const auto& it : j.at("items"))
      p.items.push_back({it.at("input").get<std::string>(), it.at("name").get<std::string>(),
                         it.at("hash").get<std::string>(), it.at("bytes_in").get<uint64_t>()});
    p.todo = j.at("todo").get<std::vector<size_t>>();
    p.reused = j.at("reused").get<std::vector<std::string>>();
  } catch (const nlohmann::json::exception& e) {
    return Status::error("batch: " + path + ": not a meshmux batch plan (" + e.what() + ")",
                         ErrorKind::kInput);
  }
  for (size_t i : p.todo)
    if (i >= p.items.size())
      return Status::error("batch: " + path + ": an input index out of range", ErrorKind::kInput);
  if (p.tasks < 1) p.tasks = 1;
  return p;
}

double now_epoch() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// "JobId=5 ArrayJobId=1 ArrayTaskId=2 ... JobState=FAILED ... ExitCode=3:0" → field value.
std::string field(const std::string& line, const std::string& key) {
  const std::string k = key + "=";
  size_t at = 0;
  while ((at = line.find(k, at)) != std::string::npos) {
    if (at == 0 || line[at - 1] == ' ') {
      const size_t start = at + k.size();
      return line.substr(start, line.find(' ', start) - start);
    }
    at += k.size();
  }
  return "";
}

// The state of each task of an array, from `scontrol -o show job ID` (one line per task; a
// pending remainder shows as one line with ArrayTaskId=a-b).
struct TaskState {
  std::string state, exit;
};
std::map<int, TaskState> array_states(const std::string& array_job) {
  std::map<int, TaskState> out;
  auto r = run_command({"scontrol", "-o", "show", "job", array_job}, 60);
  if (!r.ok()) return out;
  std::istringstream lines(r->output);
  std::string line;
  while (std::getline(lines, line)) {
    const std::string id = field(line, "ArrayTaskId");
    if (id.empty() || id.find_first_not_of("0123456789") != std::string::npos) continue;
    out[std::stoi(id)] = {field(line, "JobState"), field(line, "ExitCode")};
  }
  return out;
}

std::string job_state(const std::string& job) {
  auto r = run_command({"scontrol", "-o", "show", "job", job}, 60);
  if (!r.ok()) return "";
  return field(r->output, "JobState");
}

bool terminal(const std::string& state) {
  static const std::set<std::string> kEnded = {"COMPLETED", "FAILED",    "CANCELLED",
                                               "TIMEOUT",   "NODE_FAIL", "PREEMPTED",
                                               "BOOT_FAIL", "DEADLINE",  "OUT_OF_MEMORY"};
  return kEnded.count(state) > 0;
}

// sbatch --parsable prints "ID" or "ID;cluster".
Result<std::string> sbatch(const std::vector<std::string>& args) {
  std::vector<std::string> argv = {"sbatch", "--parsable"};
  argv.insert(argv.end(), args.begin(), args.end());
  auto r = run_command(argv, 120);
  if (!r.ok())
    return Status::error("batch: cannot submit to Slurm: " + r.status().message(),
                         ErrorKind::kUnavailable);
  std::string out = r->output;
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r' || out.back() == ' '))
    out.pop_back();
  const std::string last =
      out.substr(out.rfind('\n') == std::string::npos ? 0 : out.rfind('\n') + 1);
  const std::string id = last.substr(0, last.find(';'));
  if (r->exit.code != 0 || id.empty() || id.find_first_not_of("0123456789") != std::string::npos)
    return Status::error("batch: sbatch refused the job (" + r->exit.describe() + "): " + out,
                         ErrorKind::kUnavailable);
  return id;
}

Status write_script(const std::string& path, const std::string& body) {
  if (Status s = write_file_atomic(path, "#!/bin/sh\n" + body); !s) return s;
  chmod(path.c_str(), 0755);
  return Status::ok();
}

std::string jobs_file(const std::string& state_dir) { return state_dir + "/slurm/jobs.json"; }

}  // namespace

Status check_no_running_slurm_batch(const std::string& state_dir) {
  auto text = read_whole_file(jobs_file(state_dir), uint64_t(1) << 20);
  if (!text.ok()) return Status::ok();
  auto j = nlohmann::json::parse(text->begin(), text->end(), nullptr, false);
  if (!j.is_object()) return Status::ok();
  const std::string array = j.value("array_job", ""), summary = j.value("summary_job", "");
  if (summary.empty()) return Status::ok();
  const std::string state = job_state(summary);
  if (state.empty() || terminal(state)) return Status::ok();
  return Status::error("batch: " + state_dir.substr(0, state_dir.rfind('/')) +
                           ": a Slurm batch is still " + state + " on it (job array " + array +
                           ", summary job " + summary + "); wait for it, or scancel " + array +
                           " " + summary,
                       ErrorKind::kOutput);
}

// --wait: waits for the summary job `summary_id`, printing how many of the `todo` conversions
// have left a record since submission, then reports batch.json's counts as a local batch does.
// kExitUnavailable when the summary job ended without writing batch.json.
static int wait_for_summary(const std::string& summary_id, size_t todo,
                            const BatchOptions& options) {
  size_t shown = size_t(-1);
  const auto since = fs::file_time_type::clock::now() - std::chrono::seconds(1);
  std::string state;
  std::error_code ec;
  const std::string slurm_dir = options.state_dir + "/slurm";
  for (int misses = 0;;) {
    state = job_state(summary_id);
    if (terminal(state)) break;
    if (state.empty() && ++misses > 30) break;  // gone from the controller: read the summary
    if (!state.empty()) misses = 0;
    size_t done = 0;
    for (const auto& e : fs::directory_iterator(options.state_dir + "/records", ec))
      if (e.path().extension() == ".json" && e.last_write_time(ec) >= since) ++done;
    if (done != shown && !options.quiet) {
      std::fprintf(stderr, "meshmux: batch: %zu/%zu converted or failed (summary job %s)\n", done,
                   todo, state.c_str());
      shown = done;
    }
    std::this_thread::sleep_for(std::chrono::seconds(1));
  }
  auto text = read_whole_file(options.outroot + "/batch.json");
  auto doc = text.ok() ? nlohmann::json::parse(text->begin(), text->end(), nullptr, false)
                       : nlohmann::json();
  if (!doc.is_object() || !doc.contains("slurm") || !doc["slurm"].is_object() ||
      doc["slurm"].value("summary_job", "") != summary_id) {
    std::fprintf(stderr,
                 "meshmux: batch: the summary job %s ended %s without writing %s/batch.json; "
                 "see %s/summary.log\n",
                 summary_id.c_str(), state.empty() ? "(state unknown)" : state.c_str(),
                 options.outroot.c_str(), slurm_dir.c_str());
    return kExitUnavailable;
  }
  const auto& c = doc["counts"];
  if (!options.quiet)
    std::fprintf(stderr,
                 "meshmux: batch: %d inputs: %d converted (%d from an earlier run), %d failed, "
                 "%d not converted; wrote %s/index.html\n",
                 c.value("inputs", 0), c.value("ok", 0), c.value("reused", 0), c.value("failed", 0),
                 c.value("not_converted", 0), options.outroot.c_str());
  return c.value("failed", 0) + c.value("not_converted", 0) ? kExitSomeFailed : kExitOk;
}

int submit_slurm_batch(const std::vector<BatchItem>& all, const std::vector<BatchItem>& todo,
                       const std::vector<std::string>& reused, const BatchOptions& options,
                       const SlurmOptions& slurm) {
  Plan plan;
  plan.options = options;
  plan.options.jobs = std::max(1, slurm.cpus_per_task);
  plan.items = all;
  plan.reused = reused;
  plan.started = now_epoch();
  std::map<std::string, size_t> index;
  for (size_t i = 0; i < all.size(); ++i) index[all[i].name] = i;
  // Largest first, so round-robin shares are even.
  std::vector<BatchItem> order = todo;
  std::stable_sort(order.begin(), order.end(),
                   [](const BatchItem& a, const BatchItem& b) { return a.bytes_in > b.bytes_in; });
  for (const BatchItem& it : order) plan.todo.push_back(index.at(it.name));
  const std::string slurm_dir = options.state_dir + "/slurm";
  std::error_code ec;
  fs::create_directories(slurm_dir, ec);
  if (plan.todo.empty()) {
    // Nothing to convert: the summary needs no cluster.
    BatchSummaryInfo info;
    info.mode = "slurm";
    info.convert_args = options.convert_args;
    info.layout = options.layout;
    info.fingerprint = options.fingerprint;
    info.skipped = reused;
    auto counts = write_batch_summary(options.outroot, options.state_dir, all, info);
    if (!counts.ok()) return print_error(counts.status(), kExitOutput);
    if (!options.quiet)
      std::fprintf(stderr,
                   "meshmux: batch: every input was converted by an earlier run; "
                   "wrote %s/index.html\n",
                   options.outroot.c_str());
    return counts->failed + counts->not_converted ? kExitSomeFailed : kExitOk;
  }
  plan.tasks = slurm.tasks > 0 ? slurm.tasks : int(std::min<size_t>(plan.todo.size(), 1000));
  plan.tasks = int(std::min<size_t>(size_t(plan.tasks), plan.todo.size()));
  if (Status s = write_plan(plan); !s) return print_error(s, kExitOutput);

  const std::string exe = sh_quote(options.exe), pf = sh_quote(plan_file(options.state_dir));
  const std::string task_sh = slurm_dir + "/task.sh", summary_sh = slurm_dir + "/summary.sh";
  if (Status s = write_script(task_sh, "# meshmux batch: one task of the job array\nexec " + exe +
                                           " batch --slurm-task " + pf + "\n");
      !s)
    return print_error(s, kExitOutput);

  std::vector<std::string> common;
  if (!slurm.partition.empty()) common.push_back("--partition=" + slurm.partition);
  std::vector<std::string> array_args = common;
  array_args.insert(array_args.end(), {"--job-name=meshmux-batch",
                                       "--array=0-" + std::to_string(plan.tasks - 1) + "%" +
                                           std::to_string(std::max(1, slurm.throttle)),
                                       "--cpus-per-task=" + std::to_string(plan.options.jobs),
                                       "--output=" + sbatch_path(slurm_dir) + "/task-%a.log",
                                       "--chdir=" + options.state_dir});
  if (options.max_memory_mb)
    array_args.push_back("--mem=" +
                         std::to_string(options.max_memory_mb * plan.options.jobs + 256));
  array_args.push_back(task_sh);
  auto array_id = sbatch(array_args);
  if (!array_id.ok()) return print_error(array_id.status(), kExitUnavailable);

  if (Status s = write_script(summary_sh,
                              "# meshmux batch: the summary, after the job array\n"
                              "exec " +
                                  exe + " batch --slurm-summary " + pf + " --array-job " +
                                  *array_id + "\n");
      !s)
    return print_error(s, kExitOutput);
  std::vector<std::string> summary_args = common;
  summary_args.insert(summary_args.end(),
                      {"--job-name=meshmux-batch-summary", "--dependency=afterany:" + *array_id,
                       "--output=" + sbatch_path(slurm_dir) + "/summary.log",
                       "--chdir=" + options.state_dir, summary_sh});
  auto summary_id = sbatch(summary_args);
  if (!summary_id.ok()) {
    (void)run_command({"scancel", *array_id}, 60);
    std::fprintf(stderr, "meshmux: %s (job array %s cancelled)\n",
                 summary_id.status().message().c_str(), array_id->c_str());
    return kExitUnavailable;
  }
  {
    nlohmann::ordered_json jobs = {{"array_job", *array_id}, {"summary_job", *summary_id}};
    (void)write_file_atomic(jobs_file(options.state_dir), jobs.dump() + "\n");
  }
  if (!options.quiet)
    std::fprintf(stderr,
                 "meshmux: batch: submitted job array %s (%d tasks, at most %d at once, %zu "
                 "inputs to convert, %zu from an earlier run) and summary job %s after it\n"
                 "meshmux: batch: %s/index.html and batch.json appear when it ends (squeue -j "
                 "%s,%s); task logs in %s\n",
                 array_id->c_str(), plan.tasks, std::max(1, slurm.throttle), plan.todo.size(),
                 reused.size(), summary_id->c_str(), options.outroot.c_str(), array_id->c_str(),
                 summary_id->c_str(), slurm_dir.c_str());
  if (!slurm.wait) return kExitOk;

  return wait_for_summary(*summary_id, plan.todo.size(), options);
}

int run_slurm_task(const std::string& plan_path) {
  auto plan = read_plan(plan_path);
  if (!plan.ok()) return print_error(plan.status(), kExitInput);
  const char* id_text = std::getenv("SLURM_ARRAY_TASK_ID");
  if (!id_text)
    return std::fprintf(stderr,
                        "meshmux: batch: --slurm-task runs inside a Slurm job array "
                        "(SLURM_ARRAY_TASK_ID is not set)\n"),
           1;
  const int task = std::atoi(id_text);
  std::vector<BatchItem> share;
  for (size_t k = size_t(task); k < plan->todo.size(); k += size_t(plan->tasks))
    share.push_back(plan->items[plan->todo[k]]);
  BatchOptions o = plan->options;
  o.worker = "slurm task " + std::to_string(task);
  if (const char* cpus = std::getenv("SLURM_CPUS_PER_TASK")) o.jobs = std::max(1, std::atoi(cpus));
  o.cores = o.jobs;  // the task's allocation, not the node
  std::fprintf(stderr, "meshmux: batch: Slurm task %d of %d: %zu inputs, %d at once\n", task,
               plan->tasks, share.size(), o.jobs);
  PoolResult r = run_pool(share, o, 0, share.size());
  if (!r.usage_error.empty()) std::fprintf(stderr, "meshmux: batch: %s\n", r.usage_error.c_str());
  return r.failed || r.interrupted || !r.usage_error.empty() ? kExitSomeFailed : kExitOk;
}

int run_slurm_summary(const std::string& plan_path, const std::string& array_job) {
  auto plan = read_plan(plan_path);
  if (!plan.ok()) return print_error(plan.status(), kExitInput);
  const auto states = array_states(array_job);
  BatchSummaryInfo info;
  info.mode = "slurm";
  info.convert_args = plan->options.convert_args;
  info.layout = plan->options.layout;
  info.fingerprint = plan->options.fingerprint;
  info.seconds = now_epoch() - plan->started;
  info.skipped = plan->reused;
  info.missing_default = "not converted: its Slurm task ended without a result";
  for (size_t k = 0; k < plan->todo.size(); ++k) {
    const int task = int(k % size_t(plan->tasks));
    auto it = states.find(task);
    // A task cancelled while pending leaves no record of its own in scontrol (the array's
    // remaining ids just lose it); no record at all means Slurm forgot the array already.
    const std::string what =
        it != states.end()
            ? "ended " + it->second.state + ", exit " + it->second.exit + " before converting it"
        : !states.empty() ? "never ran (cancelled while pending)"
                          : "ended, in a state Slurm no longer knows, before converting it";
    info.missing_reason[plan->items[plan->todo[k]].name] =
        "not converted: Slurm task " + array_job + "_" + std::to_string(task) + " " + what +
        " (see .meshmux-batch/slurm/task-" + std::to_string(task) + ".log)";
  }
  nlohmann::ordered_json s;
  s["array_job"] = array_job;
  const char* self = std::getenv("SLURM_JOB_ID");
  s["summary_job"] = self ? self : "";
  s["tasks"] = nlohmann::ordered_json::array();
  for (int t = 0; t < plan->tasks; ++t) {
    auto it = states.find(t);
    s["tasks"].push_back({{"task", t},
                          {"state", it != states.end() ? it->second.state
                                    : states.empty()   ? "unknown"
                                                       : "never ran (cancelled while pending)"},
                          {"exit", it == states.end() ? "" : it->second.exit}});
  }
  info.slurm_json = s.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  auto counts =
      write_batch_summary(plan->options.outroot, plan->options.state_dir, plan->items, info);
  if (!counts.ok()) return print_error(counts.status(), kExitOutput);
  std::fprintf(stderr,
               "meshmux: batch: %zu inputs: %zu converted (%zu from an earlier run), %zu failed, "
               "%zu not converted\n",
               counts->inputs, counts->ok, counts->reused, counts->failed, counts->not_converted);
  for (const auto& [task, st] : states)
    std::fprintf(stderr, "meshmux: batch: task %s_%d %s exit %s\n", array_job.c_str(), task,
                 st.state.c_str(), st.exit.c_str());
  return counts->failed + counts->not_converted ? kExitSomeFailed : kExitOk;
}

}  // namespace meshmux
