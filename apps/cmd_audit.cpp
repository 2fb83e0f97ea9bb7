// `ccfr audit DIR`: certifies a run directory frame by frame with the exact penetration audit
// (geometry_exact). Exit codes: 0 clean, 1 penetrations found, 2 bad input.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/io/run_audit.hpp"
#include "commands.hpp"

namespace ccfr::app {

namespace {

struct AuditCliOptions {
  std::filesystem::path dir;
  io::RunAuditOptions audit;
  int threads = 0;
};

int run_audit(const AuditCliOptions& o) {
  if (o.threads > 0) set_thread_count(o.threads);
  const auto on_start = [&](const io::RunAuditResult& r) {
    std::printf("audit %s: %d vertices, %d faces, %d edges; xi = %.6g, tol = %.3g; %zu of %zu frames\n", o.dir.string().c_str(),
                r.vertices, r.faces, r.edges, r.offset, o.audit.tolerance, r.frames_checked, r.frames_total);
    std::printf("frame-0 exclusions: %d sub-pairs closer than xi, %d intersecting pairs\n", r.excluded_close_pairs,
                r.excluded_intersections);
    std::printf("%8s %12s %12s %12s %16s %12s\n", "frame", "tri_isect", "seg_cross", "close", "min_dist", "min/xi");
  };
  double xi = 0.0;
  const auto on_frame = [&](long n, const exact::FrameAudit& r) {
    std::printf("%8ld %12d %12d %12d %16.10g %12.9f\n", n, r.triangle_intersections, r.segment_crossings, r.close_pairs,
                r.min_distance, std::isfinite(r.min_distance) && xi > 0 ? r.min_distance / xi : INFINITY);
    for (const exact::AuditExample& e : r.examples) std::printf("         %s\n", e.describe().c_str());
    std::fflush(stdout);
  };
  const io::RunAuditResult res = io::audit_run(o.dir, o.audit, on_frame, [&](const io::RunAuditResult& r) {
    xi = r.offset;
    on_start(r);
  });
  if (res.clean()) {
    std::printf("PASS: %zu frames free of penetrations; min distance %.10g (%.9f xi) in %.2f s\n", res.frames_checked,
                res.min_distance, std::isfinite(res.min_distance) ? res.min_distance / res.offset : INFINITY, res.seconds);
    return 0;
  }
  std::printf("FAIL: %d violations in %zu of %zu frames; first at frame %ld%s%s\n", res.violations, res.bad_frames,
              res.frames_checked, res.first_bad_frame, res.first_example.empty() ? "" : ": ", res.first_example.c_str());
  return 1;
}

}  // namespace

void register_audit(CLI::App& app) {
  auto o = std::make_shared<AuditCliOptions>();
  auto* cmd = app.add_subcommand(
      "audit", "Check every frame of a run directory for intersections and pairs closer than the offset xi");
  cmd->add_option("dir", o->dir, "Run directory (holding run.json and frames/)")->required();
  cmd->add_option_function<double>(
         "--offset", [o](double v) { o->audit.offset = v; }, "Offset xi (default: `offset` from DIR/run.json)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--tol", o->audit.tolerance, "Relative tolerance: pairs closer than (1 - tol) xi are violations")
      ->check(CLI::Range(0.0, 0.999999))
      ->capture_default_str();
  cmd->add_option("--stride", o->audit.stride, "Audit every K-th frame (the last frame is always audited)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "Worker threads (0: all cores)")->check(CLI::NonNegativeNumber);
  cmd->callback([o] {
    init_logging("warn");
    guarded([o] { return run_audit(*o); });
  });
}

}  // namespace ccfr::app
