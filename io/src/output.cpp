#include "ccfr/io/output.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <ctime>

#include "ccfr/core/error.hpp"
#include "ccfr/io/obj.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

std::string version() { return CCFR_VERSION; }
std::string git_commit() { return CCFR_GIT_COMMIT; }

std::string utc_now() {
  std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

const std::string& stats_header() {
  static const std::string h =
      "frame,sim_time,wall_s,xpbd_s,broad_s,narrow_s,resolution_s,candidates,constraints,violations_detected,"
      "violations_remaining,halted_vertices,min_distance,penetrations,audit_s,outer_iterations,clamped_vertices,"
      "check_s,contact_vertices,substeps_run,projector_fallbacks";
  return h;
}

std::string stats_row(const FrameStats& s) {
  char buf[512];
  // min_distance is empty when no pair was within range (nothing to measure).
  char md[40] = "";
  if (std::isfinite(s.min_distance)) std::snprintf(md, sizeof md, "%.9g", s.min_distance);
  char pen[24] = "";
  if (s.penetrations >= 0) std::snprintf(pen, sizeof pen, "%d", s.penetrations);
  std::snprintf(buf, sizeof buf, "%d,%.9g,%.6f,%.6f,%.6f,%.6f,%.6f,%d,%d,%d,%d,%d,%s,%s,%.6f,%d,%d,%.6f,%d,%d,%d", s.frame,
                s.sim_time, s.wall_s, s.times.xpbd, s.times.broad, s.times.narrow, s.times.resolution, s.candidates,
                s.constraints, s.violations_detected, s.violations_remaining, s.halted_vertices, md, pen, s.times.audit,
                s.outer_iterations, s.clamped_vertices, s.times.check, s.contact_vertices, s.substeps_run,
                s.projector_fallbacks);
  return buf;
}

namespace {
std::string jstr(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    if (c == '\n') {
      o += "\\n";
      continue;
    }
    o += c;
  }
  return o + "\"";
}
std::string jnum(double v) {
  char b[40];
  auto r = std::to_chars(b, b + sizeof b, v);  // shortest text that round-trips
  return std::string(b, r.ptr);
}
}  // namespace

RunWriter::RunWriter(fs::path dir, const Topology& topo, std::string resolved_config_json, RunMeta meta)
    : dir_(std::move(dir)),
      topo_(topo),
      config_json_(std::move(resolved_config_json)),
      meta_(std::move(meta)),
      start_time_(utc_now()) {
  std::error_code ec;
  fs::create_directories(dir_ / "frames", ec);
  if (ec) throw Error("cannot create output directory '" + (dir_ / "frames").string() + "': " + ec.message());
  // A rerun into the same directory must not leave frames of the previous run behind.
  for (const auto& e : fs::directory_iterator(dir_ / "frames"))
    if (e.path().extension() == ".obj" && e.path().filename().string().rfind("frame_", 0) == 0)
      fs::remove(e.path(), ec);
  stats_.open(dir_ / "stats.csv", std::ios::trunc);
  if (!stats_) throw Error("cannot write '" + (dir_ / "stats.csv").string() + "'");
  stats_ << stats_header() << '\n';
  stats_.flush();
  write_run_json("running", false);
}

void RunWriter::write_frame(int frame, const Positions& x) {
  char name[32];
  std::snprintf(name, sizeof name, "frame_%05d.obj", frame);
  write_frame_obj(dir_ / "frames" / name, topo_, x);
  ++frames_written_;
}

void RunWriter::write_stats(const FrameStats& s) {
  stats_ << stats_row(s) << '\n';
  stats_.flush();
}

void RunWriter::finish(const std::string& status) { write_run_json(status, true); }

void RunWriter::write_run_json(const std::string& status, bool finished) {
  std::string s = "{\n";
  s += "  \"ccfr\": {\"version\": " + jstr(version()) + ", \"git_commit\": " + jstr(git_commit()) + "},\n";
  s += "  \"scene\": " + jstr(meta_.scene) + ",\n";
  s += "  \"solver\": " + jstr(meta_.solver) + ",\n";
  s += "  \"broad_phase\": " + jstr(meta_.broad_phase) + ",\n";
  s += "  \"radius\": " + jnum(meta_.radius) + ",\n";
  s += "  \"offset\": " + jnum(meta_.offset) + ",\n";
  s += "  \"repulsion_range\": " + jnum(meta_.repulsion_range) + ",\n";
  s += "  \"fps\": " + jnum(meta_.fps) + ",\n";
  s += "  \"threads\": " + std::to_string(meta_.threads) + ",\n";
  s += "  \"command_line\": " + jstr(meta_.command_line) + ",\n";
  s += "  \"start_time\": " + jstr(start_time_) + ",\n";
  s += "  \"end_time\": " + (finished ? jstr(utc_now()) : std::string("null")) + ",\n";
  s += "  \"status\": " + jstr(status) + ",\n";
  s += "  \"frames_written\": " + std::to_string(frames_written_) + ",\n";
  s += "  \"vertices\": " + std::to_string(topo_.num_vertices()) + ",\n";
  if (const auto& ip = meta_.initial_proximity) {
    s += "  \"initial_proximity\": {\"adjacent_excluded\": " + std::to_string(ip->adjacent_excluded) +
         ", \"reduced_offset_pairs\": " + std::to_string(ip->reduced_offset) +
         ", \"min_reduced_offset\": " + jnum(ip->min_reduced_offset) +
         ", \"intersecting_pairs\": " + std::to_string(ip->intersecting_pairs) +
         ", \"intersecting_excluded\": " + std::to_string(ip->intersecting_excluded) +
         ", \"shortest_edge\": " + (std::isfinite(ip->shortest_edge) ? jnum(ip->shortest_edge) : std::string("null")) +
         "},\n";
  }
  s += "  \"config\": " + config_json_ + "\n}\n";
  write_file_atomic(dir_ / "run.json", s);
}

}  // namespace ccfr::io
