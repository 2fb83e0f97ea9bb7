#pragma once
// Starting a sweep from its spec and resuming it: which cells run, and on which backend (here or
// as a Slurm job array). docs/cluster.md.
#include <filesystem>
#include <string>

#include "sweep_slurm.hpp"

namespace ccfr::app {

/// How `ccfr sweep` and `ccfr sweep resume` run the cells.
struct SweepBackend {
  std::string backend = "local";  ///< local or slurm; empty (resume only): as the sweep was started
  int jobs = 1;                   ///< local: cells run at once
  int threads = 0;                ///< local: threads per cell; 0: all cores / jobs
  SlurmFlags slurm;               ///< slurm: overrides of the spec's resources, and the sbatch command
};

/// `ccfr sweep SPEC --out OUT`: writes OUT/sweep.json (refusing an OUT that holds another sweep or
/// other files) and runs every cell; returns the command's exit code.
int start_sweep(const std::filesystem::path& spec, const std::filesystem::path& out, const SweepBackend& b);
/// `ccfr sweep resume DIR`: runs again every cell that neither completed nor is queued or running;
/// returns the command's exit code.
int resume_sweep(const std::filesystem::path& dir, const SweepBackend& b);

}  // namespace ccfr::app
