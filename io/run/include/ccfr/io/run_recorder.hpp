#pragma once
/// @file run_recorder.hpp
/// Recording a Simulation into a run directory the way `ccfr run` does, shared by the CLI's run
/// driver and the Python module, so that both write the same bytes.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "ccfr/io/output.hpp"
#include "ccfr/solvers/simulation.hpp"

namespace ccfr::exact {
class PenetrationAudit;
}

namespace ccfr::io {

/// run.json's metadata of a run of `sim` (scene, solver, r, ξ, δ, fps, initial proximity) with
/// the current thread count and the command as given; the scene fingerprint when `sim` has run no
/// frame yet (a resume sets its checkpoint's).
RunMeta make_run_meta(const Simulation& sim, std::string command_line, std::vector<std::string> argv);

/// The audit roles of the scene's objects (exact::AuditOptions::object_roles, docs/audit.md):
/// rigid bodies and obstacles moved rigidly (static, `motion`, `keyframes`) are rigid; obstacles
/// and rigid bodies with pins are scripted. The same as `ccfr audit` reads from run.json.
std::vector<std::uint8_t> audit_object_roles(const Topology& topo, const SimulationParams& params);

/// The in-simulation audit of debug.audit: the exact penetration audit of geometry_exact,
/// referenced to `initial`, with audit_object_roles(), returning stats.csv's `penetrations`. Empty (with a warning)
/// when contact.offset is 0. `audit_out` (optional) receives the audit behind the hook, whose state a checkpoint saves.
AuditHook make_audit_hook(const Topology& topo, const Positions& initial, const SimulationParams& params,
                          std::shared_ptr<exact::PenetrationAudit>* audit_out = nullptr);

/// Writes a simulation's frames, stats rows and run.json: frame 0 on start() when output.frames
/// is on, frame f after step f when f is a multiple of output.every or the last frame, a stats
/// row after every step, the status on finish(). Errors of the writer (ccfr::Error) propagate;
/// whatever was written before stays whole (RunWriter).
class RunRecorder {
 public:
  /// `last_frame`: the frame number always written (time.frames of the run); -1 when unknown (an
  /// open-ended run from Python writes every output.every-th frame only).
  RunRecorder(std::filesystem::path dir, const Simulation& sim, std::string resolved_config_json, RunMeta meta,
              int last_frame, bool force = false);
  /// Continues the run in `dir` after frame `resume.frame` (`ccfr run --resume`, RunWriter::ResumeAt):
  /// start() then writes no frame 0.
  RunRecorder(std::filesystem::path dir, const Simulation& sim, std::string resolved_config_json, RunMeta meta,
              int last_frame, RunWriter::ResumeAt resume);
  /// Writes run.json ("running"), the stats header and frame 0 (not when resuming).
  void start();
  /// Writes what belongs to the frame `s.frame` that the simulation has just finished.
  void record(const FrameStats& s);
  /// Writes the final status (RunWriter::finish).
  void finish(const std::string& status);
  RunWriter& writer() { return writer_; }

 private:
  /// Velocity and the contact solver's per-vertex diagnostics when a VTU frame is written, else empty.
  VertexFields fields() const;

  const Simulation& sim_;
  bool want_fields_ = false;
  RunWriter writer_;
  int last_frame_;
  bool resumed_ = false;
};

}  // namespace ccfr::io
