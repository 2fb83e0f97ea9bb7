#include "ccfr/io/run_audit.hpp"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/io/frame_topology.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/output.hpp"
#include "ccfr/io/run_json.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

namespace {

struct FrameFile {
  long number;
  fs::path path;
};

// Every *.obj in DIR/frames, which must all be named frame_<digits>.obj, sorted by number: a file
// the audit would skip because of its name is refused rather than left unchecked.
std::vector<FrameFile> frame_files(const fs::path& dir) {
  std::vector<FrameFile> out;
  const fs::path fdir = dir / "frames";
  if (!fs::is_directory(fdir)) return out;
  for (const auto& e : fs::directory_iterator(fdir)) {
    if (e.path().extension() != ".obj") continue;
    const std::string stem = e.path().stem().string();
    long n = -1;
    if (stem.rfind("frame_", 0) == 0 && stem.size() > 6 &&
        std::all_of(stem.begin() + 6, stem.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      const auto [p, ec] = std::from_chars(stem.data() + 6, stem.data() + stem.size(), n);
      if (ec != std::errc() || p != stem.data() + stem.size()) n = -1;
    }
    if (n < 0)
      throw Error("'" + e.path().string() + "' is not named frame_<number>.obj; frames/ must hold only frames");
    out.push_back({n, e.path()});
  }
  std::sort(out.begin(), out.end(), [](const FrameFile& a, const FrameFile& b) { return a.number < b.number; });
  for (size_t i = 1; i < out.size(); ++i)
    if (out[i].number == out[i - 1].number)
      throw Error("'" + out[i - 1].path.string() + "' and '" + out[i].path.string() + "' are both frame " +
                  std::to_string(out[i].number));
  return out;
}

constexpr size_t kMaxListedMissing = 1000000;

// The frame numbers missing from a sequence: a run writes frames 0, every, 2 every, ... and its
// last one (docs/output.md), so every multiple of `every` from `first` up to the last frame on
// disk must be there. Without run.json the step is the smallest gap between two frames present.
std::vector<long> missing_frames(const std::vector<FrameFile>& frames, long first, std::optional<long> every) {
  std::vector<long> missing;
  if (frames.empty()) return missing;
  long step = every.value_or(0);
  if (step <= 0) {
    step = 0;
    for (size_t i = 1; i < frames.size(); ++i)
      if (step == 0 || frames[i].number - frames[i - 1].number < step) step = frames[i].number - frames[i - 1].number;
    if (step <= 0) return missing;
  }
  size_t k = 0;
  const long last = frames.back().number;
  for (long n = first; n <= last; n += step) {
    while (k < frames.size() && frames[k].number < n) ++k;
    if (k == frames.size() || frames[k].number != n) missing.push_back(n);
    // Bounds on the list's cost (frame numbers may be huge), not on the check: one is enough.
    if (missing.size() >= kMaxListedMissing || n > last - step) break;
  }
  return missing;
}

std::string jstr(const std::string& s) {
  std::string o = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') {
      o += '\\';
      o += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char b[8];
      std::snprintf(b, sizeof b, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
      o += b;
    } else {
      o += c;
    }
  }
  return o + "\"";
}

// Shortest round-tripping text; null for infinity (no pair within range) and NaN.
std::string jnum(double v) {
  if (!std::isfinite(v)) return "null";
  char b[40];
  const auto r = std::to_chars(b, b + sizeof b, v);
  return std::string(b, r.ptr);
}

}  // namespace

void check_frame_sequence(const fs::path& dir, long first, std::optional<long> every, const std::string& who) {
  const std::vector<FrameFile> frames = frame_files(dir);
  const std::vector<long> missing = missing_frames(frames, first, every);
  if (missing.empty()) return;
  std::string list;
  for (size_t i = 0; i < missing.size() && i < 20; ++i) list += (i ? ", " : "") + std::to_string(missing[i]);
  if (missing.size() > 20) list += " and " + std::to_string(missing.size() - 20) + " more";
  throw Error("'" + (dir / "frames").string() +
              "' has a gap: " + (missing.size() >= kMaxListedMissing ? "at least " : "") +
              std::to_string(missing.size()) + " frame" + (missing.size() == 1 ? " is" : "s are") +
              " missing between frame " + std::to_string(first) + " and frame " + std::to_string(frames.back().number) +
              " (" + list + "); " + who + " a whole sequence only: restore the frames or run again");
}

std::string audit_options_problem(const RunAuditOptions& o) {
  const auto num = [](double x) { return ccfr::format("{:.7g}", x); };
  if (o.offset && !(std::isfinite(*o.offset) && *o.offset > 0))
    return "offset must be a finite number > 0, got " + num(*o.offset);
  if (!(o.tolerance >= 0 && o.tolerance <= kMaxAuditTolerance))
    return "tolerance must be in [0, " + num(kMaxAuditTolerance) + "], got " + num(o.tolerance);
  if (o.stride < 1) return "stride must be >= 1, got " + std::to_string(o.stride);
  return {};
}

namespace {

/// The result's description of the audit before any frame is read; throws without a positive xi.
RunAuditResult start_result(const fs::path& dir, const RunAuditOptions& o, const RunInfo& info) {
  RunAuditResult res;
  res.dir = dir;
  res.has_run_json = info.has_run_json;
  res.status = info.progress.status;
  res.offset = o.offset ? *o.offset : info.meta.contact.offset;
  res.offset_source = o.offset ? "--offset" : "run.json";
  res.tolerance = o.tolerance;
  res.stride = o.stride;
  if (!(res.offset > 0.0))
    throw Error("no positive offset xi: run.json has offset " + std::to_string(info.meta.contact.offset) +
                "; pass --offset");
  return res;
}

/// The frames on disk, which must be those run.json counts at the end of a run (not while it is
/// "running").
std::vector<FrameFile> frames_to_audit(const fs::path& dir, const RunInfo& info) {
  std::vector<FrameFile> frames = frame_files(dir);
  if (frames.empty()) throw Error("no frames in '" + (dir / "frames").string() + "'");
  if (info.has_run_json && !info.progress.status.empty() && info.progress.status != "running" &&
      info.progress.frames_written >= 0 && static_cast<size_t>(info.progress.frames_written) != frames.size())
    throw Error("'" + (dir / "run.json").string() + "' records " + std::to_string(info.progress.frames_written) +
                " frames written, but '" + (dir / "frames").string() + "' holds " + std::to_string(frames.size()));
  return frames;
}

/// The reference the exclusions come from: frame 0 (or an explicit one). A later frame as
/// reference would excuse whatever is wrong in it, e.g. a sheet intersecting the floor in every frame.
fs::path reference_frame(const fs::path& dir, const RunAuditOptions& o, const std::vector<FrameFile>& frames) {
  if (o.reference.empty()) {
    if (frames.front().number != 0)
      throw Error("'" + (dir / "frames" / "frame_00000.obj").string() +
                  "' is missing: frame 0 defines the pairs the audit excludes; pass --reference FILE (an OBJ of the "
                  "initial state with the same topology) to audit this run");
    return frames.front().path;
  }
  if (!fs::is_regular_file(o.reference)) throw Error("reference '" + o.reference.string() + "' does not exist");
  return o.reference;
}

/// Positions in `frames` of the frames audited: 0, K, 2K, ... and always the last one.
std::vector<size_t> picked_frames(size_t count, size_t stride) {
  std::vector<size_t> picks;
  for (size_t i = 0; i < count; i += stride) picks.push_back(i);
  if (picks.back() != count - 1) picks.push_back(count - 1);
  return picks;
}

/// Refuses a reference that cannot be this run's, or an offset that would excuse every pair.
void check_reference(const Frame& reference, const fs::path& dir, const RunAuditOptions& o, const RunInfo& info,
                     const RunAuditResult& res) {
  // Frames of another scene certify nothing about this run: run.json counts the run's vertices.
  if (info.has_run_json && info.progress.vertices > 0 &&
      static_cast<long>(reference.v.size()) != info.progress.vertices)
    throw Error("'" + res.reference.string() + "' has " + std::to_string(reference.v.size()) + " vertices, but '" +
                (dir / "run.json").string() + "' records " + std::to_string(info.progress.vertices) +
                ": these frames are not this run's; audit the run that wrote them");
  // An offset beyond the scene's size excludes every pair as close in frame 0 and passes anything.
  if (o.offset) {
    Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
    for (const Vec3& x : reference.v) {
      lo = lo.cwiseMin(x);
      hi = hi.cwiseMax(x);
    }
    const double size = reference.v.empty() ? 0.0 : (hi - lo).norm();
    if (!(*o.offset <= size))
      throw Error(
          ccfr::format("--offset {} is larger than the scene (the diagonal of the box of '{}' is {} m): every "
                       "pair would be excluded as close in frame 0; give the run's offset xi",
                       *o.offset, res.reference.string(), size));
  }
}

/// The roles run.json gives the objects of `topo` (rigid, scripted), counted into `res`.
std::vector<std::uint8_t> object_roles(const Topology& topo, const RunInfo& info, RunAuditResult& res) {
  std::vector<std::uint8_t> roles;
  if (info.objects.empty()) return roles;
  roles.assign(topo.objects.size(), 0);
  for (const RunInfo::RigidObject& ro : info.objects)
    for (size_t k = 0; k < topo.objects.size(); ++k)
      if (topo.objects[k].name == ro.name) {
        roles[k] = static_cast<std::uint8_t>((ro.rigid ? exact::kRigidObject : 0) |
                                             (ro.scripted ? exact::kScriptedObject : 0));
        res.rigid_objects += ro.rigid;
        res.scripted_objects += ro.scripted;
      }
  return roles;
}

/// Refuses a frame that is not this run's: another scene's fingerprint or another topology.
void check_frame(const Frame& fr, const fs::path& path, const Frame& reference, const fs::path& dir,
                 const RunInfo& info, const RunAuditResult& res) {
  // Frames a run wrote carry its scene fingerprint: another scene's frames (same topology,
  // other positions or masses) are not this run's.
  if (info.meta.scene_fingerprint != 0 && reference.scene_fingerprint != 0 &&
      fr.scene_fingerprint != info.meta.scene_fingerprint)
    throw Error(
        ccfr::format("'{}' was written by a run of scene fingerprint {:016x}, but '{}' records {:016x}: "
                     "these frames are not this run's; audit the run that wrote them",
                     path.string(), fr.scene_fingerprint, (dir / "run.json").string(), info.meta.scene_fingerprint));
  if (!same_structure(reference, fr)) {
    topology_from_frame(fr, path);  // names the offending line if the frame itself is malformed
    throw Error("the topology of '" + path.string() + "' differs from the reference '" + res.reference.string() +
                "' (objects, faces, lines or points)");
  }
}

/// Adds frame n's audit `r` to the result: its row and the run's totals.
void record_frame(RunAuditResult& res, long n, const fs::path& path, const exact::FrameAudit& r) {
  FrameAuditRow row;
  row.frame = n;
  row.file = path.filename().string();
  row.triangle_intersections = r.triangle_intersections;
  row.segment_crossings = r.segment_crossings;
  row.close_pairs = r.close_pairs;
  row.rigid_deformations = r.rigid_deformations;
  row.scene_pairs = r.scene_pairs;
  row.min_distance = r.min_distance;
  for (const exact::AuditExample& e : r.examples) row.examples.push_back(e.describe());
  for (const exact::AuditExample& e : r.scene_examples) row.scene_examples.push_back(e.describe());
  if (res.rigid_objects > 0 && r.rigid_deformations == 0) ++res.rigid_frames;
  if (r.scene_pairs > 0) {
    res.scene_pairs += r.scene_pairs;
    ++res.scene_frames;
    if (res.first_scene_frame < 0) {
      res.first_scene_frame = n;
      if (!r.scene_examples.empty()) res.first_scene_example = r.scene_examples.front().describe();
    }
  }
  res.rows.push_back(std::move(row));
  res.min_distance = std::min(res.min_distance, r.min_distance);
  res.violations += r.penetrations();
  if (!r.clean()) {
    ++res.bad_frames;
    if (res.first_bad_frame < 0) {
      res.first_bad_frame = n;
      if (!r.examples.empty()) res.first_example = r.examples.front().describe();
    }
  }
}

}  // namespace

RunAuditResult audit_run(const fs::path& dir, const RunAuditOptions& o, const FrameAuditCallback& on_frame,
                         const std::function<void(const RunAuditResult&)>& on_start) {
  if (const std::string problem = audit_options_problem(o); !problem.empty()) throw Error("audit: " + problem);
  if (!fs::is_directory(dir)) throw Error("'" + dir.string() + "' is not a directory" + previous_run_note(dir));
  if (!o.offset && !fs::exists(dir / "run.json"))
    throw Error("'" + (dir / "run.json").string() +
                "' is missing: pass --offset XI to audit frames without a run.json" + previous_run_note(dir));
  const RunInfo info = read_run_info(dir, /*require_run_json=*/!o.offset.has_value());
  RunAuditResult res = start_result(dir, o, info);
  const std::vector<FrameFile> frames = frames_to_audit(dir, info);
  res.reference = reference_frame(dir, o, frames);

  // A sequence with a hole certifies nothing about the hole: refuse it, naming what is missing.
  check_frame_sequence(dir, o.reference.empty() ? 0 : frames.front().number,
                       info.has_run_json ? std::optional<long>(info.meta.every) : std::optional<long>(),
                       "the audit certifies");

  const std::vector<size_t> picks = picked_frames(frames.size(), static_cast<size_t>(res.stride));
  res.frames_total = frames.size();
  res.frames_checked = picks.size();

  const auto t0 = std::chrono::steady_clock::now();
  const Frame reference = read_frame_obj(res.reference);
  check_reference(reference, dir, o, info, res);
  exact::AuditOptions opt;
  opt.offset = res.offset;
  opt.tolerance = o.tolerance;
  Topology topo = topology_from_frame(reference, res.reference);
  opt.object_roles = object_roles(topo, info, res);
  exact::PenetrationAudit audit(std::move(topo), reference.v, opt);
  res.excluded_close_pairs = audit.excluded_close_pairs();
  res.reduced_offset_pairs = audit.reduced_offset_pairs();
  res.excluded_intersections = audit.excluded_intersections();
  res.vertices = audit.topology().num_vertices();
  res.faces = audit.topology().num_faces();
  res.edges = audit.topology().num_edges();
  res.unreferenced_vertices = unreferenced_vertices(audit.topology());
  if (on_start) on_start(res);

  for (const size_t i : picks) {
    const fs::path& path = frames[i].path;
    const Frame fr = path == res.reference ? reference : read_frame_obj(path);
    check_frame(fr, path, reference, dir, info, res);
    const exact::FrameAudit r = audit.audit_next(fr.v);  // in frame order: raises the reduced offsets
    record_frame(res, frames[i].number, path, r);
    if (on_frame) on_frame(frames[i].number, r);
  }
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

std::string audit_report_json(const RunAuditResult& r, const std::string& verdict, int exit_code, bool partial) {
  std::string s = "{\n";
  auto field = [&](const char* key, const std::string& value) { s += "  " + jstr(key) + ": " + value + ",\n"; };
  field("verdict", jstr(verdict));
  field("exit_code", std::to_string(exit_code));
  field("status", r.has_run_json ? jstr(r.status) : "null");
  field("partial", partial ? "true" : "false");
  field("offset", jnum(r.offset));
  field("offset_source", jstr(r.offset_source));
  field("tolerance", jnum(r.tolerance));
  field("stride", std::to_string(r.stride));
  field("frames_checked", std::to_string(r.frames_checked));
  field("frames_total", std::to_string(r.frames_total));
  field("reference", jstr(r.reference.string()));
  field("vertices", std::to_string(r.vertices));
  field("faces", std::to_string(r.faces));
  field("edges", std::to_string(r.edges));
  field("unreferenced_vertices", std::to_string(r.unreferenced_vertices));
  field("excluded_close_pairs", std::to_string(r.excluded_close_pairs));
  field("excluded_intersections", std::to_string(r.excluded_intersections));
  field("reduced_offset_pairs", std::to_string(r.reduced_offset_pairs));
  field("rigid_objects", std::to_string(r.rigid_objects));
  field("scripted_objects", std::to_string(r.scripted_objects));
  field("rigid_frames", std::to_string(r.rigid_frames));
  field("scene_error", r.scene_error() ? "true" : "false");
  field("scene_pairs", std::to_string(r.scene_pairs));
  field("scene_frames", std::to_string(r.scene_frames));
  field("first_scene_frame", r.first_scene_frame >= 0 ? std::to_string(r.first_scene_frame) : "null");
  field("violations", std::to_string(r.violations));
  field("bad_frames", std::to_string(r.bad_frames));
  field("first_bad_frame", r.first_bad_frame >= 0 ? std::to_string(r.first_bad_frame) : "null");
  field("min_distance", jnum(r.min_distance));
  field("seconds", jnum(r.seconds));
  s += "  \"frames\": [";
  for (size_t i = 0; i < r.rows.size(); ++i) {
    const FrameAuditRow& f = r.rows[i];
    s += i == 0 ? "\n" : ",\n";
    s += "    {\"frame\": " + std::to_string(f.frame) + ", \"file\": " + jstr(f.file) +
         ", \"triangle_intersections\": " + std::to_string(f.triangle_intersections) +
         ", \"segment_crossings\": " + std::to_string(f.segment_crossings) +
         ", \"close_pairs\": " + std::to_string(f.close_pairs) + ", \"min_distance\": " + jnum(f.min_distance) +
         ", \"examples\": [";
    for (size_t k = 0; k < f.examples.size(); ++k) s += (k ? ", " : "") + jstr(f.examples[k]);
    s += "]";
    // Only where they are not zero, so the rows of a scene without rigid or scripted objects read as before.
    if (f.rigid_deformations > 0) s += ", \"rigid_deformations\": " + std::to_string(f.rigid_deformations);
    if (f.scene_pairs > 0) {
      s += ", \"scene_pairs\": " + std::to_string(f.scene_pairs) + ", \"scene_examples\": [";
      for (size_t k = 0; k < f.scene_examples.size(); ++k) s += (k ? ", " : "") + jstr(f.scene_examples[k]);
      s += "]";
    }
    s += "}";
  }
  s += r.rows.empty() ? "]\n}\n" : "\n  ]\n}\n";
  return s;
}

std::string audit_error_json(const std::string& message, int exit_code) {
  return "{\n  \"verdict\": \"error\",\n  \"exit_code\": " + std::to_string(exit_code) +
         ",\n  \"error\": " + jstr(message) + "\n}\n";
}

int audit_exit_code(const RunAuditResult& result, const std::string& verdict) {
  if (verdict == "fail") return 1;
  if (verdict == "incomplete") return 4;
  return result.scene_error() ? 5 : 0;
}

std::string audit_verdict(const RunAuditResult& result, bool partial) {
  if (!result.clean()) return "fail";
  if (result.has_run_json && !result.completed() && !partial) return "incomplete";
  return "pass";
}

}  // namespace ccfr::io
