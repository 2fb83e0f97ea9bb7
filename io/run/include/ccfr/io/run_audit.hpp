#pragma once
/// @file run_audit.hpp
/// The exact penetration audit over a run directory (frames/frame_*.obj), used by `ccfr audit`
/// and `ccfr ablate`.
#include <filesystem>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ccfr/geometry_exact/audit.hpp"

namespace ccfr::io {

/// Largest `tolerance` of an audit (`ccfr audit --tol`, Python's `tolerance=`): 1 would accept any
/// pair, however close.
inline constexpr double kMaxAuditTolerance = 0.999999;

struct RunAuditOptions {
  std::optional<double> offset;  ///< ξ; default: `offset` of DIR/run.json
  double tolerance = 1e-6;       ///< pairs closer than (1 - tol) ξ are violations
  int stride = 1;                ///< audit every K-th frame; the last frame always
  /// OBJ with the frames' topology whose positions define the frame-0 exclusions; empty: the
  /// run's frames/frame_00000.obj, which must then exist.
  std::filesystem::path reference;
};

/// Why `o` is not admissible, naming the option ("stride must be >= 1, got 0"); empty if it is:
/// offset finite and > 0 when given, tolerance in [0, kMaxAuditTolerance], stride >= 1. The CLI
/// checks the same bounds with its validators; Python raises ValueError with this text.
std::string audit_options_problem(const RunAuditOptions& o);

/// One audited frame.
struct FrameAuditRow {
  long frame = 0;
  std::string file;  ///< file name in DIR/frames
  Index triangle_intersections = 0, segment_crossings = 0, close_pairs = 0;
  Index rigid_deformations = 0;  ///< rigid objects no longer a rigid transform of frame 0 (violations)
  Index scene_pairs = 0;         ///< pairs between two scripted objects (a scene error, not violations)
  double min_distance = std::numeric_limits<double>::infinity();
  std::vector<std::string> examples, scene_examples;
  bool clean() const { return triangle_intersections + segment_crossings + close_pairs + rigid_deformations == 0; }
};

struct RunAuditResult {
  std::filesystem::path dir;
  double offset = 0.0;
  std::string offset_source;  ///< "run.json" or "--offset"
  double tolerance = 0.0;
  int stride = 1;
  std::filesystem::path reference;  ///< the file whose positions define the exclusions
  bool has_run_json = false;
  std::string status;  ///< run.json `status`; empty without run.json or without the key
  size_t frames_checked = 0, frames_total = 0, bad_frames = 0;
  Index violations = 0;  ///< summed penetrations over the checked frames
  long first_bad_frame = -1;
  std::string first_example;
  double min_distance = std::numeric_limits<double>::infinity();
  /// Frame-0 sub-pairs closer than xi and adjacent on a mesh (excluded), primitive pairs crossing at
  /// frame 0 (excluded), and close sub-pairs that are not adjacent (checked against a reduced offset).
  Index excluded_close_pairs = 0, excluded_intersections = 0, reduced_offset_pairs = 0;
  Index vertices = 0, faces = 0, edges = 0;
  Index unreferenced_vertices = 0;  ///< vertices in no face, segment or particle object: not audited
  /// Objects run.json names as rigid (rigid bodies, obstacles moved rigidly) and as scripted
  /// (obstacles, rigid bodies driven by pins); docs/audit.md, "Rigid and scripted objects".
  Index rigid_objects = 0, scripted_objects = 0;
  /// Audited frames in which every rigid object moved rigidly (its inner pairs not tested).
  size_t rigid_frames = 0;
  /// Pairs between two scripted objects over the checked frames: the scene drives them into each
  /// other. Not violations: the method passes, the scene is flagged (exit code 5).
  Index scene_pairs = 0;
  size_t scene_frames = 0;
  long first_scene_frame = -1;
  std::string first_scene_example;
  double seconds = 0.0;
  std::vector<FrameAuditRow> rows;  ///< the audited frames, in frame order
  bool clean() const { return bad_frames == 0; }
  /// run.json says the run completed. A directory without run.json has no status to check.
  bool completed() const { return status == "completed"; }
  bool scene_error() const { return scene_pairs > 0; }
};

/// Called after each audited frame with its number and result (for progress tables).
using FrameAuditCallback = std::function<void(long frame, const exact::FrameAudit&)>;

/// Audits DIR. Throws ccfr::Error on bad input: missing directory, run.json missing without an
/// explicit offset, no frames, a .obj in frames/ not named frame_<number>.obj, frame 0 missing
/// without a reference, unreadable or non-finite frames, topology differing from the reference,
/// a completed run.json whose frames_written differs from the frames on disk.
/// Throws ccfr::Error naming the missing frames when DIR/frames/frame_*.obj has a gap: a run writes
/// frames first, first + every, ... up to its last one (without `every`, the smallest gap present).
/// `who` completes the message: "the audit certifies", "export writes".
void check_frame_sequence(const std::filesystem::path& dir, long first, std::optional<long> every,
                          const std::string& who);

RunAuditResult audit_run(const std::filesystem::path& dir, const RunAuditOptions& options,
                         const FrameAuditCallback& on_frame = {},
                         const std::function<void(const RunAuditResult&)>& on_start = {});

/// The verdict of an audit (docs/audit.md): "fail" when a checked frame is not clean; "incomplete"
/// when clean but run.json says the run did not complete and `partial` is off; else "pass".
std::string audit_verdict(const RunAuditResult& result, bool partial);
/// The exit code of `ccfr audit` for a verdict (docs/audit.md): 1 fail, 4 incomplete, 5 pass with
/// a scene error (scripted objects driven into each other), 0 pass.
int audit_exit_code(const RunAuditResult& result, const std::string& verdict);

/// The audit report written to DIR/audit.json (docs/audit.md): `verdict` ("pass", "fail",
/// "incomplete"), `exit_code`, `partial` and the fields of `result`.
std::string audit_report_json(const RunAuditResult& result, const std::string& verdict, int exit_code, bool partial);
/// The report of an audit that could not run (`verdict` "error").
std::string audit_error_json(const std::string& message, int exit_code);

}  // namespace ccfr::io
