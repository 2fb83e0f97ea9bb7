#pragma once
// The Slurm backend of `ccfr sweep`: one job array with one task per cell, submitted with sbatch
// and followed with squeue and sacct. docs/cluster.md.
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "sweep_layout.hpp"

namespace ccfr::app {

/// Slurm settings given on the command line; unset ones (-1, empty) leave the spec's resources.
struct SlurmFlags {
  int cpus = -1;
  std::string time, memory, partition, account;
  std::string sbatch = "sbatch";
};

/// Overrides `r` with every flag of `f` that is set.
void apply_flags(io::SweepResources& r, const SlurmFlags& f);
/// Slurm refuses array indices at or above its MaxArraySize: the cluster's (scontrol show config),
/// else Slurm's default 1001. Throws naming both before anything is written or submitted.
void check_slurm_array_size(const SweepLayout& s, const std::vector<size_t>& indices);
/// Writes DIR/sweep.sbatch (one array task per cell) and submits `indices` of it with `sbatch`;
/// records the job in DIR/sweep.json and returns its id.
std::string slurm_submit(const SweepLayout& s, const std::vector<size_t>& indices, const std::string& sbatch);
/// Why squeue may have failed, for its messages: most often the cluster's SLURM_CONF is not set in
/// this shell (scripts/slurm-local prints the line that sets it).
std::string slurm_conf_hint();
/// Slurm's view of the sweep's array tasks: cell index -> state (PENDING, RUNNING, COMPLETED,
/// CANCELLED, TIMEOUT, FAILED, ...) of its latest job; squeue for live tasks, sacct when accounting
/// is available (without it sacct fails and only run.json tells). `*queue_known` (if given): squeue
/// answered.
std::map<size_t, std::string> slurm_states(const std::filesystem::path& dir, bool* queue_known = nullptr);

}  // namespace ccfr::app
