// The Slurm backend (sweep_slurm.hpp): DIR/sweep.sbatch, its submission as a job array recorded in
// DIR/sweep.json, and the tasks' states as squeue and sacct report them.
#include "sweep_slurm.hpp"

#include <spdlog/spdlog.h>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <sstream>

#include "ccfr/core/error.hpp"
#include "ccfr/io/dir_lock.hpp"
#include "ccfr/io/obj.hpp"
#include "sweep_shell.hpp"

namespace ccfr::app {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

namespace {

// Array index list "0-3,7" of sorted indices.
std::string array_list(const std::vector<size_t>& idx) {
  std::string s;
  for (size_t i = 0; i < idx.size();) {
    size_t j = i;
    while (j + 1 < idx.size() && idx[j + 1] == idx[j] + 1) ++j;
    s += (s.empty() ? "" : ",") + std::to_string(idx[i]) + (j > i ? "-" + std::to_string(idx[j]) : "");
    i = j + 1;
  }
  return s;
}

}  // namespace

void apply_flags(io::SweepResources& r, const SlurmFlags& f) {
  if (f.cpus > 0) r.cpus_per_task = f.cpus;
  if (!f.time.empty()) r.time = f.time;
  if (!f.memory.empty()) r.memory = f.memory;
  if (!f.partition.empty()) r.partition = f.partition;
  if (!f.account.empty()) r.account = f.account;
}

void check_slurm_array_size(const SweepLayout& s, const std::vector<size_t>& indices) {
  if (indices.empty()) return;
  long max_array = 1001;
  std::string source = "Slurm's default; `scontrol show config` did not say";
  const auto [code, out] = capture("scontrol show config");
  if (const size_t at = out.find("MaxArraySize"); code == 0 && at != std::string::npos) {
    const size_t eq = out.find('=', at);
    if (eq != std::string::npos) {
      const long v = std::strtol(out.c_str() + eq + 1, nullptr, 10);
      if (v > 0) max_array = v, source = "`scontrol show config`";
    }
  }
  if (static_cast<long>(indices.back()) < max_array) return;
  throw Error("the sweep's array would need task index " + std::to_string(indices.back()) + " (" +
              std::to_string(s.cells.size()) + " cells), but Slurm's MaxArraySize is " + std::to_string(max_array) +
              " (" + source + "): sbatch would refuse it; split the grid into specs of at most " +
              std::to_string(max_array) + " cells (docs/cluster.md)");
}

std::string slurm_submit(const SweepLayout& s, const std::vector<size_t>& indices, const std::string& sbatch) {
  check_slurm_array_size(s, indices);
  const fs::path dir = fs::absolute(s.dir).lexically_normal();
  const auto& r = s.resources;
  std::string sh =
      "#!/bin/bash\n# Written by ccfr sweep: one array task per cell of " + dir.string() +
      "/sweep.json.\n#SBATCH --job-name=ccfr-sweep\n#SBATCH --cpus-per-task=" + std::to_string(r.cpus_per_task) + "\n";
  if (!r.time.empty()) sh += "#SBATCH --time=" + r.time + "\n";
  if (!r.memory.empty()) sh += "#SBATCH --mem=" + r.memory + "\n";
  if (!r.partition.empty()) sh += "#SBATCH --partition=" + r.partition + "\n";
  if (!r.account.empty()) sh += "#SBATCH --account=" + r.account + "\n";
  sh += "#SBATCH --output=" + (dir / "logs" / "slurm-%A_%a.out").string() + "\n#SBATCH --chdir=" + dir.string() +
        "\n# SIGTERM (scancel, the time limit) makes the cell write a checkpoint; `ccfr sweep resume` continues it.\n" +
        "exec " + single_quote(self_exe().string()) + " sweep run-cell " + single_quote(dir.string()) +
        " \"$SLURM_ARRAY_TASK_ID\" --threads \"${SLURM_CPUS_PER_TASK:-1}\"\n";
  const fs::path script = dir / "sweep.sbatch";
  io::write_file_atomic(script, sh);
  fs::permissions(script, fs::perms::owner_exec, fs::perm_options::add);
  const std::string array = array_list(indices);
  const auto [code, out] = capture(sbatch + " --parsable --array=" + array + " " + single_quote(script.string()));
  if (code != 0) throw Error("sbatch failed (exit " + std::to_string(code) + "): " + out);
  std::string job = out.substr(0, out.find_first_of(";\n"));
  if (job.empty() || job.find_first_not_of("0123456789") != std::string::npos)
    throw Error("sbatch printed no job id: '" + out + "'");
  Json j = read_json(dir / "sweep.json");
  j["slurm_jobs"].push_back({{"job_id", job}, {"array", array}, {"submitted", io::utc_now()}});
  io::write_file_atomic(dir / "sweep.json", j.dump(2) + "\n");
  std::printf("sweep: submitted job %s (array %s, %zu cells) with %s; `ccfr sweep status %s` follows it\n", job.c_str(),
              array.c_str(), indices.size(), script.string().c_str(), dir.string().c_str());
  return job;
}

std::string slurm_conf_hint() {
  const char* conf = std::getenv("SLURM_CONF");
  if (!conf || !*conf)
    return "SLURM_CONF is not set: set it as for the sbatch that submitted the sweep, e.g. "
           "eval \"$(scripts/slurm-local env)\" for the single-machine cluster";
  return std::string("SLURM_CONF is ") + conf + ": is that cluster running?";
}

std::map<size_t, std::string> slurm_states(const fs::path& dir, bool* queue_known) {
  std::map<size_t, std::string> st;
  const Json j = read_json(dir / "sweep.json");
  if (!j.is_object() || !j.contains("slurm_jobs") || !j.at("slurm_jobs").is_array() || j.at("slurm_jobs").empty())
    return st;
  std::string ids;
  for (const auto& job : j.at("slurm_jobs"))
    if (job.is_object() && job.contains("job_id") && job.at("job_id").is_string())
      ids += (ids.empty() ? "" : ",") + job.at("job_id").get<std::string>();
  auto parse = [&](const std::string& text, char sep) {
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
      const size_t us = line.find('_'), sp = line.find(sep);
      if (us == std::string::npos || sp == std::string::npos || sp < us) continue;
      const std::string task = line.substr(us + 1, sp - us - 1);
      if (task.empty() || task.find_first_not_of("0123456789") != std::string::npos) continue;
      std::string state = line.substr(sp + 1);
      state = state.substr(0, state.find_first_of(" \t"));
      st[std::stoul(task)] = state;  // later jobs come later: the latest state wins
    }
  };
  const auto [sc, sacct] = capture("sacct -n -P -X -j " + ids + " -o JobID,State");
  if (sc == 0) parse(sacct, '|');
  const auto [qc, squeue] = capture("squeue -h -r -j " + ids + " -o '%i %T'");
  if (queue_known) *queue_known = qc == 0;
  if (qc == 0)
    parse(squeue, ' ');
  else  // e.g. SLURM_CONF not set as for sbatch: queued cells would look not started, running ones lost
    spdlog::warn("sweep: squeue failed (exit {}): {}; queued and running cells are not known as such ({})", qc,
                 squeue.substr(0, squeue.find('\n')), slurm_conf_hint());
  return st;
}

}  // namespace ccfr::app
