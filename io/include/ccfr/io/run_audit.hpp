#pragma once
/// @file run_audit.hpp
/// The exact penetration audit over a run directory (frames/frame_*.obj), used by `ccfr audit`
/// and `ccfr ablate`.
#include <filesystem>
#include <functional>
#include <limits>
#include <optional>
#include <string>

#include "ccfr/geometry_exact/audit.hpp"

namespace ccfr::io {

struct RunAuditOptions {
  std::optional<double> offset;  ///< ξ; default: `offset` of DIR/run.json
  double tolerance = 1e-6;       ///< pairs closer than (1 - tol) ξ are violations
  int stride = 1;                ///< audit every K-th frame; the last frame always
};

struct RunAuditResult {
  double offset = 0.0;
  size_t frames_checked = 0, frames_total = 0, bad_frames = 0;
  Index violations = 0;          ///< summed penetrations over the checked frames
  long first_bad_frame = -1;
  std::string first_example;
  double min_distance = std::numeric_limits<double>::infinity();
  Index excluded_close_pairs = 0, excluded_intersections = 0;
  Index vertices = 0, faces = 0, edges = 0;
  double seconds = 0.0;
  bool clean() const { return bad_frames == 0; }
};

/// Called after each audited frame with its number and result (for progress tables).
using FrameAuditCallback = std::function<void(long frame, const exact::FrameAudit&)>;

/// Audits DIR. Throws ccfr::Error on bad input: missing directory or run.json (without an
/// explicit offset), no frames, unreadable or non-finite frames, topology changing between frames.
RunAuditResult audit_run(const std::filesystem::path& dir, const RunAuditOptions& options,
                         const FrameAuditCallback& on_frame = {}, const std::function<void(const RunAuditResult&)>& on_start = {});

}  // namespace ccfr::io
