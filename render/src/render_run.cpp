#include "ccfr/render/render_run.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/io/obj.hpp"

extern char** environ;

namespace ccfr::render {

namespace fs = std::filesystem;

namespace {
constexpr double kSubjectTrim = 0.02;  ///< fraction of subject vertices ignored at each end of each axis
}  // namespace

std::vector<size_t> select_frames(size_t count, int every) {
  std::vector<size_t> picked;
  if (count == 0) return picked;
  const size_t k = static_cast<size_t>(std::max(every, 1));
  for (size_t i = 0; i < count; i += k) picked.push_back(i);
  if (picked.back() != count - 1) picked.push_back(count - 1);
  return picked;
}

Bounds scan_obj_bounds(const fs::path& path) { return scan_obj_bounds(path, {}); }

Bounds scan_obj_bounds(const fs::path& path, const std::vector<std::string>& exclude, double trim) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open '" + path.string() + "'");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  Bounds b;
  const char* s = text.c_str();
  const char* end = s + text.size();
  // Only "v x y z" lines matter for bounds, and "o"/"g" lines for `exclude`; everything else is
  // skipped line by line.
  bool skipping = false;
  std::array<std::vector<double>, 3> coords;  // only with trim > 0
  long line = 0, vertex = 0;
  while (s < end) {
    const void* nl = std::memchr(s, '\n', static_cast<size_t>(end - s));
    const char* line_end = nl ? static_cast<const char*>(nl) : end;
    if (!exclude.empty() && (s[0] == 'o' || s[0] == 'g') && s + 1 < end && (s[1] == ' ' || s[1] == '\t')) {
      std::string name(s + 2, line_end);
      while (!name.empty() && std::isspace(static_cast<unsigned char>(name.back()))) name.pop_back();
      while (!name.empty() && std::isspace(static_cast<unsigned char>(name.front()))) name.erase(name.begin());
      skipping = std::find(exclude.begin(), exclude.end(), name) != exclude.end();
    }
    ++line;
    if (s[0] == 'v' && s + 1 < end && (s[1] == ' ' || s[1] == '\t')) {
      ++vertex;
      const char* q = s + 2;
      Vec3 p = Vec3::Zero();
      bool ok = true;
      for (int c = 0; c < 3 && ok; ++c) {
        char* next = nullptr;
        p[c] = std::strtod(q, &next);
        ok = next != q;
        // A coordinate the reader would refuse must not reach the camera fit (a camera at 1e200
        // makes rays Embree asserts on): the same message as read_frame_obj's.
        if (ok && !(std::abs(p[c]) <= kMaxCoordinate)) {
          while (q < next && std::isspace(static_cast<unsigned char>(*q))) ++q;
          const std::string tok(q, static_cast<const char*>(next));
          throw Error(path.string() + ":" + std::to_string(line) + ": vertex " + std::to_string(vertex) + ": " +
                      (std::isfinite(p[c]) ? "coordinate '" + tok + "' is beyond +-1e6, ccfr's bound on coordinates"
                                           : "non-finite coordinate '" + tok + "' (NaN or inf)"));
        }
        q = next;
      }
      if (ok && !skipping) {
        b.extend(p);
        if (trim > 0)
          for (int c = 0; c < 3; ++c) coords[c].push_back(p[c]);
      }
    }
    s = nl ? line_end + 1 : end;
  }
  // Per axis, the k-th smallest and k-th largest coordinate instead of the extremes.
  const size_t n = coords[0].size();
  const size_t k = static_cast<size_t>(std::floor(std::min(trim, 0.49) * static_cast<double>(n)));
  if (k == 0) return b;
  for (int c = 0; c < 3; ++c) {
    std::vector<double>& v = coords[c];
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    b.lo[c] = v[k];
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(n - 1 - k), v.end());
    b.hi[c] = v[n - 1 - k];
  }
  return b;
}

namespace {
/// "frame_00012" -> "frame 12"; other stems are shown as they are.
std::string label_of(const fs::path& obj) {
  const std::string stem = obj.stem().string();
  const size_t digits = stem.find_last_not_of("0123456789");
  if (digits != std::string::npos && digits + 1 < stem.size()) {
    const std::string number = stem.substr(digits + 1);
    const size_t nz = number.find_first_not_of('0');
    return "frame " + (nz == std::string::npos ? std::string("0") : number.substr(nz));
  }
  return stem;
}

}  // namespace

bool make_video(const std::vector<fs::path>& images, double fps, const fs::path& mp4, std::string& message) {
  const auto ffmpeg = find_program("ffmpeg");
  if (!ffmpeg) {
    message = "ffmpeg is not installed (apt-get install ffmpeg): no video written";
    return false;
  }
  if (images.empty()) {
    message = "no frames to put in a video";
    return false;
  }
  // ffmpeg's image2 demuxer wants consecutive numbers; the PNGs keep their frame numbers, so
  // link them under consecutive names in a scratch folder.
  const fs::path scratch = mp4.parent_path() / (".video-" + std::to_string(::getpid()));
  std::error_code ec;
  fs::remove_all(scratch, ec);
  fs::create_directories(scratch);
  for (size_t i = 0; i < images.size(); ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "%06zu.png", i);
    fs::create_symlink(fs::absolute(images[i]), scratch / name, ec);
    if (ec) fs::copy_file(images[i], scratch / name, fs::copy_options::overwrite_existing);
  }
  char rate[32];
  std::snprintf(rate, sizeof rate, "%.6g", fps > 0 ? fps : 30.0);
  const fs::path tmp = mp4.parent_path() / (".tmp-" + std::to_string(::getpid()) + "-" + mp4.filename().string());
  auto encode = [&](const std::string& codec) {
    return run_process({ffmpeg->string(), "-y", "-loglevel", "error", "-framerate", rate, "-i",
                        (scratch / "%06d.png").string(), "-c:v", codec, "-pix_fmt", "yuv420p", "-vf",
                        "pad=ceil(iw/2)*2:ceil(ih/2)*2", tmp.string()});
  };
  // libx264 is the common H.264 encoder; builds without it still have the native mpeg4 one.
  int rc = encode("libx264");
  if (rc != 0) rc = encode("mpeg4");
  fs::remove_all(scratch, ec);
  if (rc != 0) {
    fs::remove(tmp, ec);
    message = "ffmpeg failed (exit code " + std::to_string(rc) + "): no video written";
    return false;
  }
  fs::rename(tmp, mp4, ec);
  if (ec) {
    message = "cannot move the video to '" + mp4.string() + "': " + ec.message();
    return false;
  }
  return true;
}

RunRenderSummary render_frames(const std::vector<fs::path>& frames, const RunRenderOptions& options,
                               const ProgressCallback& progress) {
  RunRenderSummary summary;
  if (frames.empty()) throw Error("no frames to render");
  if (options.out.empty()) throw Error("no output folder given for the pictures");
  std::error_code ec;
  fs::create_directories(options.out, ec);
  if (ec || !fs::is_directory(options.out))
    throw Error("cannot create the output folder '" + options.out.string() +
                "': " + (ec ? ec.message() : std::string("a file of that name is in the way")));

  const std::vector<size_t> picked = select_frames(frames.size(), options.every);
  Bounds bounds;
  for (size_t i : picked) bounds.extend(scan_obj_bounds(frames[i]));

  // The fitted camera looks at the subject: the objects not in frame_exclude (the floor and other
  // obstacles), without the 2 % of vertices farthest out along each axis (a few grains falling off
  // the floor), widened by a fifth of their size each way so their surroundings stay in view.
  std::optional<Camera> camera = options.camera;
  if (!camera && !options.frame_exclude.empty()) {
    Bounds subject;
    for (size_t i : picked) subject.extend(scan_obj_bounds(frames[i], options.frame_exclude, kSubjectTrim));
    if (!subject.empty()) {
      const Vec3 pad = Vec3::Constant(0.2 * std::max(subject.diagonal(), 1e-9));
      subject.extend(subject.lo - pad);
      subject.extend(subject.hi + pad);
      const double aspect = static_cast<double>(std::max(options.render.width, 1)) / std::max(options.render.height, 1);
      camera = fit_camera(subject, aspect, options.render.up, options.render.fov_deg);
    }
  }
  const io::Frame first = io::read_frame_obj(frames[picked.front()]);
  summary.view = resolve_view(bounds, first, options.render, camera);

  // Tiles of the contact sheet: evenly spaced over the drawn frames, the first and last included.
  std::vector<size_t> sheet_slots;
  if (options.sheet) {
    const size_t n = std::min<size_t>(picked.size(), static_cast<size_t>(std::max(options.sheet_frames, 1)));
    for (size_t k = 0; k < n; ++k)
      sheet_slots.push_back(
          n == 1 ? 0 : static_cast<size_t>(std::lround(static_cast<double>(k) * (picked.size() - 1) / (n - 1))));
  }
  std::vector<Image> tiles;
  std::vector<std::string> labels;
  const int tile_w = std::max(16, std::min(options.sheet_tile_width, options.render.width));
  const int tile_h = std::max(1, static_cast<int>(std::lround(static_cast<double>(tile_w) * options.render.height /
                                                              std::max(options.render.width, 1))));

  Renderer renderer;
  double render_seconds = 0.0;
  for (size_t j = 0; j < picked.size(); ++j) {
    const fs::path& obj = frames[picked[j]];
    const io::Frame frame = j == 0 ? first : io::read_frame_obj(obj);
    const auto t0 = std::chrono::steady_clock::now();
    RenderResult result = renderer.render(frame, summary.view, options.render);
    render_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const fs::path png = options.out / (obj.stem().string() + ".png");
    write_png(png, result.image);
    summary.images.push_back(png);
    if (std::find(sheet_slots.begin(), sheet_slots.end(), j) != sheet_slots.end()) {
      tiles.push_back(resize(result.image, tile_w, tile_h));
      labels.push_back(label_of(obj));
    }
    if (progress) progress(static_cast<int>(j + 1), static_cast<int>(picked.size()), png);
  }
  summary.seconds_per_frame = render_seconds / static_cast<double>(picked.size());

  if (options.sheet && !tiles.empty()) {
    summary.sheet = options.out / "sheet.png";
    write_png(summary.sheet, contact_sheet(tiles, labels, options.sheet_columns));
  }
  if (options.video) {
    const fs::path mp4 = options.out / "video.mp4";
    const double rate = options.fps / std::max(options.every, 1);
    if (make_video(summary.images, rate, mp4, summary.video_note)) summary.video = mp4;
  }
  return summary;
}

}  // namespace ccfr::render
