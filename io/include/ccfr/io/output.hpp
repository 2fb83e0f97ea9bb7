#pragma once
/// @file output.hpp
/// The output directory contract: run.json, frames/frame_NNNNN.obj, stats.csv (DESIGN "Contracts").
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include "ccfr/collision/narrow_phase.hpp"
#include "ccfr/core/scene.hpp"
#include "ccfr/solvers/simulation.hpp"

namespace ccfr::io {

/// The stats.csv header, in column order.
const std::string& stats_header();
/// One stats.csv row (no trailing newline).
std::string stats_row(const FrameStats& s);

struct RunMeta {
  std::string scene, solver, broad_phase;
  double radius = 0, offset = 0, repulsion_range = 0, fps = 0;
  int threads = 0;
  std::string command_line;
  /// What the initial configuration did to contact (clarification 5), when the solver detects.
  std::optional<InitialProximity> initial_proximity;
};

/// Writes a run directory. Frames and run.json are written atomically; stats rows are flushed
/// one whole line at a time, so an interrupted run leaves every finished frame readable.
class RunWriter {
 public:
  RunWriter(std::filesystem::path dir, const Topology& topo, std::string resolved_config_json, RunMeta meta);
  /// Writes frames/frame_NNNNN.obj.
  void write_frame(int frame, const Positions& x);
  void write_stats(const FrameStats& s);
  /// Rewrites run.json with the end time, the number of frames written and a status
  /// ("completed", or the error that stopped the run).
  void finish(const std::string& status);
  const std::filesystem::path& dir() const { return dir_; }
  int frames_written() const { return frames_written_; }

 private:
  void write_run_json(const std::string& status, bool finished);

  std::filesystem::path dir_;
  const Topology& topo_;
  std::string config_json_;
  RunMeta meta_;
  std::string start_time_;
  std::ofstream stats_;
  int frames_written_ = 0;
};

/// ISO-8601 UTC timestamp of now.
std::string utc_now();
/// Library version and git commit baked in at build time.
std::string version();
std::string git_commit();

}  // namespace ccfr::io
