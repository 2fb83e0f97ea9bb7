// `ccfr audit DIR`: certifies a run directory frame by frame with the exact penetration audit
// (geometry_exact). Exit codes: 0 clean, 1 penetrations found, 2 bad input.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry_exact/audit.hpp"
#include "ccfr/io/frame_topology.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/run_info.hpp"
#include "commands.hpp"

namespace ccfr::app {

namespace {

namespace fs = std::filesystem;

struct AuditCliOptions {
  fs::path dir;
  std::optional<double> offset;
  double tolerance = 1e-6;
  int stride = 1;
  int threads = 0;
};

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

int run_audit(const AuditCliOptions& o) {
  if (!fs::is_directory(o.dir)) throw Error("'" + o.dir.string() + "' is not a directory");
  if (o.threads > 0) set_thread_count(o.threads);
  const io::RunInfo info = io::read_run_info(o.dir, /*require_run_json=*/!o.offset.has_value());
  const double xi = o.offset ? *o.offset : info.offset;
  if (!(xi > 0.0))
    throw Error("no positive offset xi: run.json has offset " + std::to_string(info.offset) + "; pass --offset");
  if (info.frames.empty()) throw Error("no frames in '" + (o.dir / "frames").string() + "'");

  // Frames 0, K, 2K, ... and always the last one.
  std::vector<size_t> picks;
  for (size_t i = 0; i < info.frames.size(); i += static_cast<size_t>(o.stride)) picks.push_back(i);
  if (picks.back() != info.frames.size() - 1) picks.push_back(info.frames.size() - 1);

  const io::Frame frame0 = io::read_frame_obj(info.frames[0]);
  exact::AuditOptions opt;
  opt.offset = xi;
  opt.tolerance = o.tolerance;
  const auto t0 = std::chrono::steady_clock::now();
  const exact::PenetrationAudit audit(io::topology_from_frame(frame0), frame0.v, opt);
  std::printf("audit %s: %d vertices, %d faces, %d edges; xi = %.6g, tol = %.3g; %zu of %zu frames\n",
              o.dir.string().c_str(), audit.topology().num_vertices(), audit.topology().num_faces(),
              audit.topology().num_edges(), xi, o.tolerance, picks.size(), info.frames.size());
  std::printf("frame-0 exclusions: %d sub-pairs closer than xi, %d intersecting pairs\n",
              audit.excluded_close_pairs(), audit.excluded_intersections());
  std::printf("%8s %12s %12s %12s %16s %12s\n", "frame", "tri_isect", "seg_cross", "close", "min_dist", "min/xi");

  size_t bad_frames = 0;
  long first_bad = -1;
  std::string first_example;
  double overall_min = std::numeric_limits<double>::infinity();
  Index total = 0;
  for (const size_t i : picks) {
    const io::Frame fr = i == 0 ? frame0 : io::read_frame_obj(info.frames[i]);
    if (!io::same_structure(frame0, fr))
      throw Error("the topology of '" + info.frames[i].string() + "' differs from frame 0's (objects, faces, lines or points)");
    const exact::FrameAudit r = audit.audit(fr.v);
    const long n = frame_number(info.frames[i], i);
    overall_min = std::min(overall_min, r.min_distance);
    total += r.penetrations();
    std::printf("%8ld %12d %12d %12d %16.10g %12.9f\n", n, r.triangle_intersections, r.segment_crossings,
                r.close_pairs, r.min_distance, std::isfinite(r.min_distance) ? r.min_distance / xi : INFINITY);
    if (!r.clean()) {
      ++bad_frames;
      if (first_bad < 0) {
        first_bad = n;
        if (!r.examples.empty()) first_example = r.examples.front().describe();
      }
      for (const exact::AuditExample& e : r.examples) std::printf("         %s\n", e.describe().c_str());
    }
    std::fflush(stdout);
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (bad_frames == 0) {
    std::printf("PASS: %zu frames free of penetrations; min distance %.10g (%.9f xi) in %.2f s\n", picks.size(),
                overall_min, std::isfinite(overall_min) ? overall_min / xi : INFINITY, secs);
    return 0;
  }
  std::printf("FAIL: %d violations in %zu of %zu frames; first at frame %ld%s%s\n", total, bad_frames, picks.size(),
              first_bad, first_example.empty() ? "" : ": ", first_example.c_str());
  return 1;
}

}  // namespace

void register_audit(CLI::App& app) {
  auto o = std::make_shared<AuditCliOptions>();
  auto* cmd = app.add_subcommand(
      "audit", "Check every frame of a run directory for intersections and pairs closer than the offset xi");
  cmd->add_option("dir", o->dir, "Run directory (holding run.json and frames/)")->required();
  cmd->add_option_function<double>(
         "--offset", [o](double v) { o->offset = v; }, "Offset xi (default: `offset` from DIR/run.json)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--tol", o->tolerance, "Relative tolerance: pairs closer than (1 - tol) xi are violations")
      ->check(CLI::Range(0.0, 0.999999))
      ->capture_default_str();
  cmd->add_option("--stride", o->stride, "Audit every K-th frame (the last frame is always audited)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "Worker threads (0: all cores)")->check(CLI::NonNegativeNumber);
  cmd->callback([o] {
    init_logging("warn");
    guarded([o] { return run_audit(*o); });
  });
}

}  // namespace ccfr::app
