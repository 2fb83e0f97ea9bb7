#pragma once
// The local backend of sweeps and ablations: the cells run here as child processes, a few at a
// time under one progress, and a stop signal reaches every one of them. docs/cluster.md.
#include <string>
#include <vector>

#include "sweep_layout.hpp"

namespace ccfr::app {

/// Runs `indices` here, `jobs` at once with `threads` each, as `ccfr sweep run-cell` processes
/// logging to DIR/logs/<id>.log. One progress (progress.hpp) on stderr over all of them: frames
/// done of the frames to run, elapsed time, ETA, and the running cells' frames; `label` ("sweep",
/// "ablate") starts its lines. Returns the number of cells that failed.
/// SIGINT or SIGTERM while it runs is passed on to every running cell, which finishes its frame,
/// writes its checkpoint and status and exits; no further cell starts, every running one is waited
/// for, and `*stopped_by` (if given) receives the signal (0 when none came).
int run_local(const SweepLayout& s, const std::vector<size_t>& indices, int jobs, int threads,
              const std::string& label = "sweep", int* stopped_by = nullptr);
/// The exit code of a sweep or ablation stopped by `sig` (docs/cluster.md): 128 + sig, as a shell
/// reports a process killed by it (130 for SIGINT, 143 for SIGTERM).
inline int interrupted_exit_code(int sig) { return 128 + sig; }
/// "SIGINT", "SIGTERM" (or "signal N").
std::string signal_name(int sig);

}  // namespace ccfr::app
