#pragma once
// `ccfr sweep status DIR`: what each cell of a sweep is now (queued, running, completed, or why it
// stopped), from Slurm's view of its tasks, the cells' locks and their run.json.
#include <filesystem>
#include <map>
#include <string>

#include "sweep_layout.hpp"

namespace ccfr::app {

/// What cell i is now: queued / running (Slurm, or a live process holding its lock), completed, or
/// why it stopped (cancelled, timeout, terminated, interrupted, failed, lost, not started).
/// `slurm`: slurm_states() of the sweep.
std::string cell_state(const SweepLayout& s, size_t i, const std::map<size_t, std::string>& slurm);
/// True for a cell_state that `sweep resume` runs again: neither completed nor queued nor running.
bool resumable(const std::string& state);
/// Prints every cell's state and frames, the counts by state, and the next command; returns 0.
int sweep_status(const std::filesystem::path& dir);

}  // namespace ccfr::app
