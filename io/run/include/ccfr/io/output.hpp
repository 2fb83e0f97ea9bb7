#pragma once
/// @file output.hpp
/// The output directory contract: run.json, frames/frame_NNNNN.obj, stats.csv (docs/output.md).
/// What run.json holds is RunMeta and RunProgress (run_json.hpp).
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/io/dir_lock.hpp"
#include "ccfr/io/formats.hpp"
#include "ccfr/io/run_json.hpp"
#include "ccfr/io/stats_csv.hpp"
#include "ccfr/solvers/simulation.hpp"

namespace ccfr::io {

/// True if DIR/run.json is a JSON object with the ccfr marker (`"ccfr": {"version": ...}`).
bool is_ccfr_run(const std::filesystem::path& dir);
/// Why DIR is not a ccfr run, for messages: "no run.json", "run.json is unreadable: ...
/// (truncated or damaged)" or "run.json was not written by ccfr"; empty when is_ccfr_run(dir).
std::string run_json_problem(const std::filesystem::path& dir);
/// "; DIR's earlier run is in 'DIR.ccfr-old' (...)" when a rerun killed while it replaced DIR left
/// it there, for messages about a missing run.json; empty otherwise.
std::string previous_run_note(const std::filesystem::path& dir);

/// True if `name` is an entry ccfr writes into a run directory (run.json, stats.csv, frames/,
/// checkpoints/, audit.json, render/, vtk/, blender/, usd/, stats.png, a folder named by a
/// registered frame writer's key, their temporaries) or the directory's lock file: what a rerun
/// replaces. Anything else in a run directory is the user's.
bool is_run_entry(const std::string& name);

/// Writes a run directory (docs/output.md). Frames and run.json are written atomically (temporary
/// file + rename, the temporary removed on failure); run.json is rewritten after every frame so
/// that `frames_written` is right even after SIGKILL; stats rows are written whole or not at all.
/// Any failed write throws ccfr::Error naming the file and the system's reason. The directory's
/// lock (DirLock) is held from the constructor to the destructor: a second writer is refused.
///
/// Where it writes: a missing or empty DIR is written directly. A non-empty DIR that is a ccfr run
/// is left untouched while the new run writes into the sibling `DIR.ccfr-new`; once the first
/// simulated frame is written (or a run of 0 frames completes) the previous run's own entries
/// (is_run_entry) are moved out and the new ones in, entry by entry; every other file of DIR (the
/// user's notes, the scene file, analyses) stays where it is. A run that stops before that is
/// discarded and the previous run stays. Any other non-empty DIR is refused unless `force`, and
/// even then if it holds an entry of ccfr's name (frames/, stats.csv, ...) that ccfr did not write.
class RunWriter {
 public:
  /// Checks and prepares DIR; throws ccfr::Error if it cannot be used (exit code 2 in `ccfr run`).
  RunWriter(std::filesystem::path dir, const Topology& topo, std::string resolved_config_json, RunMeta meta,
            bool force = false);
  /// Continues the run in DIR after frame `resume_frame` (`ccfr run --resume`): run.json keeps its
  /// start time and gains a `resumed` entry, frames after `resume_frame` and stats rows after it are
  /// removed (the resumed run writes them again). Throws ccfr::Error if DIR is not a ccfr run or
  /// its stats.csv lacks a row of frames 1 to `resume_frame`.
  struct ResumeAt {
    int frame = 0;
  };
  RunWriter(std::filesystem::path dir, const Topology& topo, std::string resolved_config_json, RunMeta meta,
            ResumeAt resume);
  ~RunWriter();
  RunWriter(const RunWriter&) = delete;
  RunWriter& operator=(const RunWriter&) = delete;
  /// Writes run.json ("running") and the stats.csv header.
  void start();
  /// Writes the frame in every format of RunMeta::formats (frames/frame_NNNNN.obj, ...), then
  /// rewrites run.json with the new frames_written. `fields` feed the VTU point data.
  void write_frame(int frame, const Positions& x, const VertexFields& fields = {});
  /// True if a format of the run reads the VertexFields beyond the positions (vtu).
  bool wants_fields() const;
  /// Appends one stats row; the first row puts a staged run in place of the previous one.
  void write_stats(const FrameStats& s);
  /// Rewrites run.json with the end time, the number of frames written and a status
  /// ("completed", or the error that stopped the run). A staged run that has not replaced the
  /// previous one yet does so if `status` is "completed", and is discarded otherwise.
  void finish(const std::string& status);
  /// Where the run is being written now (DIR, or DIR.ccfr-new while staged).
  const std::filesystem::path& dir() const { return dir_; }
  int frames_written() const { return frames_written_; }
  /// run.json's `stop` (a JSON object; empty: none): why the run stopped (Simulation::stop_report).
  void set_stop(std::string stop_json) { stop_json_ = std::move(stop_json); }
  /// True while the run is written beside a previous one that it has not replaced yet.
  bool staged() const { return staged_; }
  /// True once finish() discarded a staged run (the previous run in DIR was kept).
  bool discarded() const { return discarded_; }
  /// What could not be cleaned up after the run was in place (the previous run's files that could
  /// not be removed, and where they are now), empty if nothing: the run then exits non-zero.
  const std::string& cleanup_error() const { return cleanup_error_; }

 private:
  void write_run_json(const std::string& status, bool finished);
  void make_sinks();  ///< one FrameSink per format of meta_.formats, in that order
  void write_stats_line(const std::string& line);
  void commit();
  void discard();

  DirLock lock_;
  std::filesystem::path dir_, final_, staging_;
  const Topology& topo_;
  std::string config_json_;
  RunMeta meta_;
  std::vector<std::unique_ptr<FrameSink>> sinks_;
  std::string start_time_;
  int stats_fd_ = -1;
  long long stats_size_ = 0;
  int frames_written_ = 0;
  bool staged_ = false, discarded_ = false;
  int resume_frame_ = -1;            ///< frame resumed after; -1: a fresh run
  long long resume_stats_size_ = 0;  ///< bytes of stats.csv kept (header and rows up to resume_frame_)
  std::string resumed_json_;         ///< run.json `resumed` (JSON array), empty for a fresh run
  std::string cleanup_error_;
  std::string stop_json_;  ///< run.json `stop` (JSON object), empty unless set_stop()
};

/// Library version and git commit baked in at build time.
std::string version();
std::string git_commit();

}  // namespace ccfr::io
