#include "ccfr/io/run_audit.hpp"

#include <chrono>
#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/io/frame_topology.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/run_info.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

namespace {
// "frames/frame_00042.obj" -> 42; the list position if the name carries no number.
long frame_number(const fs::path& p, size_t position) {
  const std::string stem = p.stem().string();
  const auto us = stem.rfind('_');
  if (us != std::string::npos) {
    char* end = nullptr;
    const long n = std::strtol(stem.c_str() + us + 1, &end, 10);
    if (end && *end == '\0' && end != stem.c_str() + us + 1) return n;
  }
  return static_cast<long>(position);
}
}  // namespace

RunAuditResult audit_run(const fs::path& dir, const RunAuditOptions& o, const FrameAuditCallback& on_frame,
                         const std::function<void(const RunAuditResult&)>& on_start) {
  if (!fs::is_directory(dir)) throw Error("'" + dir.string() + "' is not a directory");
  const RunInfo info = read_run_info(dir, /*require_run_json=*/!o.offset.has_value());
  RunAuditResult res;
  res.offset = o.offset ? *o.offset : info.offset;
  if (!(res.offset > 0.0))
    throw Error("no positive offset xi: run.json has offset " + std::to_string(info.offset) + "; pass --offset");
  if (info.frames.empty()) throw Error("no frames in '" + (dir / "frames").string() + "'");
  const size_t stride = static_cast<size_t>(std::max(1, o.stride));

  // Frames 0, K, 2K, ... and always the last one.
  std::vector<size_t> picks;
  for (size_t i = 0; i < info.frames.size(); i += stride) picks.push_back(i);
  if (picks.back() != info.frames.size() - 1) picks.push_back(info.frames.size() - 1);
  res.frames_total = info.frames.size();
  res.frames_checked = picks.size();

  const auto t0 = std::chrono::steady_clock::now();
  const Frame frame0 = read_frame_obj(info.frames[0]);
  exact::AuditOptions opt;
  opt.offset = res.offset;
  opt.tolerance = o.tolerance;
  exact::PenetrationAudit audit(topology_from_frame(frame0), frame0.v, opt);
  res.excluded_close_pairs = audit.excluded_close_pairs();
  res.excluded_intersections = audit.excluded_intersections();
  res.vertices = audit.topology().num_vertices();
  res.faces = audit.topology().num_faces();
  res.edges = audit.topology().num_edges();
  if (on_start) on_start(res);

  for (const size_t i : picks) {
    const Frame fr = i == 0 ? frame0 : read_frame_obj(info.frames[i]);
    if (!same_structure(frame0, fr))
      throw Error("the topology of '" + info.frames[i].string() +
                  "' differs from frame 0's (objects, faces, lines or points)");
    const exact::FrameAudit r = audit.audit_next(fr.v);  // in frame order: raises the reduced offsets
    const long n = frame_number(info.frames[i], i);
    res.min_distance = std::min(res.min_distance, r.min_distance);
    res.violations += r.penetrations();
    if (!r.clean()) {
      ++res.bad_frames;
      if (res.first_bad_frame < 0) {
        res.first_bad_frame = n;
        if (!r.examples.empty()) res.first_example = r.examples.front().describe();
      }
    }
    if (on_frame) on_frame(n, r);
  }
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

}  // namespace ccfr::io
