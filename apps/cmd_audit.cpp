// `ccfr audit DIR`: certifies a run directory frame by frame with the exact penetration audit
// (geometry_exact) and writes DIR/audit.json. Exit codes (docs/audit.md): 0 clean, 1 penetrations
// found, 2 bad input, 3 internal error, 4 clean but the run did not complete (without --partial),
// 5 clean for the method but the scene drives two scripted objects into each other.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/run_audit.hpp"
#include "commands.hpp"
#include "progress.hpp"
#include "run_driver.hpp"

namespace ccfr::app {

namespace {

constexpr int kExitBadInput = 2;  // the others come from io::audit_exit_code

struct AuditCliOptions {
  std::filesystem::path dir;
  io::RunAuditOptions audit;
  std::filesystem::path json;  ///< report file; default DIR/audit.json
  bool partial = false;
  int threads = 0;
};

std::string ordinal(int k) {
  const int mod100 = k % 100, mod10 = k % 10;
  const char* suffix = (mod100 >= 11 && mod100 <= 13) ? "th"
                       : mod10 == 1                   ? "st"
                       : mod10 == 2                   ? "nd"
                       : mod10 == 3                   ? "rd"
                                                      : "th";
  return std::to_string(k) + suffix;
}

// "all 121 frames checked" or "every 5th frame and the last: 26 of 123 checked".
std::string coverage(const io::RunAuditResult& r) {
  if (r.frames_checked == r.frames_total) return "all " + std::to_string(r.frames_total) + " frames checked";
  const bool last_extra = (r.frames_total - 1) % static_cast<size_t>(r.stride) != 0;
  return "every " + ordinal(r.stride) + " frame" + (last_extra ? " and the last" : "") + ": " +
         std::to_string(r.frames_checked) + " of " + std::to_string(r.frames_total) + " checked";
}

std::string status_text(const io::RunAuditResult& r) {
  if (!r.has_run_json) return "unknown (no run.json)";
  if (r.status.empty()) return "unknown (run.json has no status)";
  return r.status;
}

int run_audit(const AuditCliOptions& o) {
  if (o.threads > 0) set_thread_count(o.threads);
  const std::filesystem::path json = o.json.empty() ? o.dir / "audit.json" : o.json;
  try {
    const auto on_start = [&](const io::RunAuditResult& r) {
      std::printf("audit %s: %d vertices, %d faces, %d edges; xi = %.6g (%s), tol = %.3g\n", o.dir.string().c_str(),
                  r.vertices, r.faces, r.edges, r.offset, r.offset_source.c_str(), r.tolerance);
      std::printf("run status: %s\n", status_text(r).c_str());
      std::printf("frames: %s\n", coverage(r).c_str());
      if (r.unreferenced_vertices > 0)
        std::printf("%d vertices belong to no face, segment or particle object (tet interiors?) and are not audited\n",
                    r.unreferenced_vertices);
      std::printf(
          "initial proximity from %s: %d adjacent sub-pairs closer than xi and %d intersecting pairs excluded; "
          "%d sub-pairs closer than xi checked against a reduced offset\n",
          r.reference.string().c_str(), r.excluded_close_pairs, r.excluded_intersections, r.reduced_offset_pairs);
      if (r.rigid_objects + r.scripted_objects > 0)
        std::printf(
            "%d rigid objects (pairs inside one are skipped while it moves rigidly), %d scripted objects (pairs "
            "between two are a scene error, not a violation)\n",
            r.rigid_objects, r.scripted_objects);
      std::printf("%8s %12s %12s %12s %16s %12s\n", "frame", "tri_isect", "seg_cross", "close", "min_dist", "min/xi");
    };
    double xi = 0.0;
    // The table rows go to stdout; the bar on stderr is erased before each row and redrawn after.
    std::optional<ProgressReporter> progress;
    long audited = 0;
    const auto on_frame = [&](long n, const exact::FrameAudit& r) {
      if (progress) progress->clear();
      std::printf("%8ld %12d %12d %12d %16.10g %12.9f\n", n, r.triangle_intersections, r.segment_crossings,
                  r.close_pairs, r.min_distance,
                  std::isfinite(r.min_distance) && xi > 0 ? r.min_distance / xi : INFINITY);
      for (const exact::AuditExample& e : r.examples) std::printf("         %s\n", e.describe().c_str());
      if (r.scene_pairs > 0)
        std::printf("         scene error: %d pairs between scripted objects, e.g. %s\n", r.scene_pairs,
                    r.scene_examples.empty() ? "?" : r.scene_examples.front().describe().c_str());
      std::fflush(stdout);
      if (progress) progress->update(++audited, "frame " + std::to_string(n));
    };
    const io::RunAuditResult res = io::audit_run(o.dir, o.audit, on_frame, [&](const io::RunAuditResult& r) {
      xi = r.offset;
      on_start(r);
      progress.emplace("audit frame", static_cast<long>(r.frames_checked), 5.0);
    });
    if (progress) progress->finish();

    // A run without run.json has no status to check; a run.json that does not say "completed"
    // (running: killed or still going; interrupted; failed) only passes with --partial.
    const bool unfinished = res.has_run_json && !res.completed();
    std::string scope = coverage(res);
    if (unfinished) scope = "partial run, status '" + status_text(res) + "'; " + scope;
    const std::string verdict = io::audit_verdict(res, o.partial);
    // 0, 1, 4, or 5 for a pass whose scene drives scripted objects into each other.
    const int code = io::audit_exit_code(res, verdict);
    char line[8192];
    if (verdict == "fail") {
      std::snprintf(line, sizeof line, "FAIL (%s): %d violations in %zu frames; first at frame %ld%s%s", scope.c_str(),
                    res.violations, res.bad_frames, res.first_bad_frame, res.first_example.empty() ? "" : ": ",
                    res.first_example.c_str());
    } else if (verdict == "incomplete") {
      std::snprintf(line, sizeof line,
                    "INCOMPLETE (%s): the frames checked are clean, but the run did not complete; pass --partial to "
                    "accept the frames present",
                    scope.c_str());
    } else {
      std::snprintf(line, sizeof line,
                    "PASS (%s): no intersection, crossing or pair closer than (1 - tol) xi; min distance %.10g (%.9f "
                    "xi) in %.2f s",
                    scope.c_str(), res.min_distance,
                    std::isfinite(res.min_distance) ? res.min_distance / res.offset : INFINITY, res.seconds);
    }
    std::string last = line;
    // Scripted objects driven into each other: no solver can move them, so the method's verdict
    // stands, and the scene is flagged with its own line and exit code.
    if (res.scene_error()) {
      std::printf("%s\n", last.c_str());
      std::snprintf(line, sizeof line,
                    "SCENE ERROR: the scene drives scripted objects into each other (not the method's failure): %d "
                    "pairs in %zu frames; first at frame %ld%s%s",
                    res.scene_pairs, res.scene_frames, res.first_scene_frame,
                    res.first_scene_example.empty() ? "" : ": ", res.first_scene_example.c_str());
      last = line;
    }
    // The last line ends with what to look at next: a failure's violations per frame, an
    // unfinished run's frames, a clean run's pictures.
    const std::string d = shell_quote(o.dir.string());
    last += "; next: " + (verdict == "fail"         ? "ccfr plot " + d
                          : verdict == "incomplete" ? "ccfr audit --partial " + d
                                                    : "ccfr render " + d + " --sheet");
    std::printf("%s\n", last.c_str());
    std::fflush(stdout);
    io::write_file_atomic(json, io::audit_report_json(res, verdict, code, unfinished && o.partial));
    return code;
  } catch (const Error& e) {
    // A stale report of an earlier audit must not outlive this one.
    if (std::filesystem::is_directory(json.parent_path().empty() ? "." : json.parent_path())) {
      try {
        io::write_file_atomic(json, io::audit_error_json(e.what(), kExitBadInput));
      } catch (const Error&) {
      }
    }
    throw;
  }
}

}  // namespace

void register_audit(CLI::App& app) {
  auto o = std::make_shared<AuditCliOptions>();
  auto* cmd = app.add_subcommand(
      "audit",
      "Check every frame of a run directory (or any OBJ sequence, with --offset) for triangle intersections, "
      "strands through triangles and pairs closer than the offset xi; report in DIR/audit.json");
  cmd->add_option("dir", o->dir, "Run directory (holding frames/frame_NNNNN.obj and, unless --offset, run.json)")
      ->required();
  cmd->add_option_function<double>(
         "--offset", [o](double v) { o->audit.offset = v; },
         "Offset xi (default: `offset` from DIR/run.json; with --offset, run.json may be absent)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--tol", o->audit.tolerance, "Relative tolerance: pairs closer than (1 - tol) xi are violations")
      ->check(CLI::Range(0.0, io::kMaxAuditTolerance))
      ->capture_default_str();
  cmd->add_option("--stride", o->audit.stride, "Audit every K-th frame (the last frame is always audited)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--reference", o->audit.reference,
                  "OBJ of the initial state (same topology as the frames) defining the frame-0 exclusions; "
                  "required when frames/frame_00000.obj is missing");
  cmd->add_flag(
      "--partial", o->partial,
      "Accept a run that did not complete (run.json status other than `completed`): audit the frames present");
  cmd->add_option("--json", o->json, "Write the report here instead of DIR/audit.json");
  cmd->add_option("--threads", o->threads, "Worker threads (0: all cores)")->check(CLI::NonNegativeNumber);
  cmd->callback([o] {
    init_logging("warn");
    guarded([o] { return run_audit(*o); });
  });
}

}  // namespace ccfr::app
