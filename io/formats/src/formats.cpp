// What the frame writers (frame_writers/*.cpp, one per format) share: the registry, the resume
// of a run's sinks, the replay of frames read back (`ccfr export`), per-frame file helpers.
#include "ccfr/io/formats.hpp"

#include <algorithm>
#include <cstdio>
#include <string>
#include <system_error>

#include "builtin_frame_writers.hpp"
#include "ccfr/core/error.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

FrameWriterRegistry& frame_writers() {
  static FrameWriterRegistry registry = [] {
    FrameWriterRegistry r("output format");
#define CCFR_BUILTIN_FRAME_WRITER(key) register_frame_writer_##key(r);
#include "builtin_frame_writers.inc"
#undef CCFR_BUILTIN_FRAME_WRITER
    return r;
  }();
  return registry;
}

std::vector<std::string> frame_writer_names() { return frame_writers().names(); }

std::vector<std::string> parse_output_formats(const std::vector<std::string>& names) {
  std::vector<std::string> out;
  for (const auto& n : names) {
    if (!frame_writers().find(n)) {
      std::string list;
      for (const auto& k : frame_writer_names()) list += (list.empty() ? "" : ", ") + k;
      throw Error("unknown output format '" + n + "' (supported: " + list + ")");
    }
    if (std::find(out.begin(), out.end(), n) == out.end()) out.push_back(n);
  }
  return out;
}

std::unique_ptr<FrameSink> make_frame_sink(const std::string& format, const FrameSinkContext& ctx,
                                           const ParamValues& params) {
  return frame_writers().make(format, params, ctx);
}

std::string frame_name(int frame, const char* ext) {
  char name[40];
  std::snprintf(name, sizeof name, "frame_%05d.%s", frame, ext);
  return name;
}

void make_dir(const fs::path& d) {
  std::error_code ec;
  fs::create_directories(d, ec);
  if (ec) throw Error("cannot create directory '" + d.string() + "': " + ec.message());
}

/// A per-frame format on resume: every frame written before the checkpoint must be on disk (else
/// the finished run would have a gap).
void check_frames_before(const fs::path& folder, const char* ext, const ResumedFrames& before) {
  for (int f : before.frames) {
    std::error_code ec;
    const fs::path p = folder / frame_name(f, ext);
    if (!fs::is_regular_file(p, ec))
      throw Error("cannot resume: '" + p.string() + "' (written before the checkpoint of frame " +
                  std::to_string(before.last) + ") is missing; the finished run would have a gap: restore it or run " +
                  "again");
  }
}

/// ... and the frames after it, left by the interrupted run, go.
void keep_frames_before(const fs::path& folder, const char* ext, const ResumedFrames& before) {
  check_frames_before(folder, ext, before);
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(folder, ec)) {
    const std::string n = e.path().filename().string();
    const std::string suffix = std::string(".") + ext;
    if (n.size() != 11 + suffix.size() || n.rfind("frame_", 0) != 0 || n.substr(11) != suffix) continue;
    const std::string digits = n.substr(6, 5);
    if (digits.find_first_not_of("0123456789") != std::string::npos || std::stoi(digits) <= before.last) continue;
    std::error_code rec;
    fs::remove(e.path(), rec);
    if (rec) throw Error("cannot remove '" + e.path().string() + "': " + rec.message());
  }
}

void FrameSink::resume(const fs::path& dir, const ResumedFrames& before) {
  if (before.frames.empty()) return;
  if (!before.positions)
    throw Error("cannot resume '" + dir.string() +
                "': its whole-run files (usda) are rebuilt from the frames written before the checkpoint, and "
                "output.formats has neither obj nor pc2 to read them from: run again");
  replay_frames({this}, dir, before.frames, before.positions, before.fps, false);
}

void replay_frames(const std::vector<FrameSink*>& sinks, const fs::path& dir, const std::vector<int>& frames,
                   const FramePositions& positions, double fps, bool velocities) {
  Positions prev;
  int prev_frame = 0;
  for (size_t k = 0; k < frames.size(); ++k) {
    const int frame = frames[k];
    Positions x = positions(k, frame);
    VertexFields fields;
    if (velocities) {
      fields.velocity.assign(x.size(), Vec3::Zero());
      if (!prev.empty() && frame > prev_frame)
        for (size_t v = 0; v < x.size(); ++v) fields.velocity[v] = (x[v] - prev[v]) * fps / (frame - prev_frame);
    }
    for (FrameSink* s : sinks) s->write(dir, frame, fps > 0 ? frame / fps : 0.0, x, fields);
    prev_frame = frame;
    prev = std::move(x);
  }
}

void resume_frame_sinks(const std::vector<FrameSink*>& sinks, const fs::path& dir, int last,
                        const std::vector<int>& frames, double fps) {
  ResumedFrames before{last, frames, {}, fps};
  // OBJ frames hold the exact positions; PC2 holds them as float, which is all USDA writes. Read
  // before any sink changes a file: a USDA layer alone is rebuilt from its samples file.
  FrameSink* source = nullptr;
  for (FrameSink* s : sinks)
    if (s->saved_precision() > (source ? source->saved_precision() : 0)) source = s;
  if (source && !frames.empty()) before.positions = source->saved_positions(dir, frames);
  // Whatever can refuse the resume runs before any file changes: the per-frame files are checked
  // here, the USDA layer only reads (it is written at the end), the PC2 caches check themselves
  // before they are cut; the frames after the checkpoint are removed last.
  for (FrameSink* s : sinks) s->check_resume(dir, before);
  std::vector<FrameSink*> order(sinks);
  std::stable_sort(order.begin(), order.end(),
                   [](const FrameSink* a, const FrameSink* b) { return a->resume_order() < b->resume_order(); });
  for (FrameSink* s : order) s->resume(dir, before);
}

}  // namespace ccfr::io
