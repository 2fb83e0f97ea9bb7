// `ccfr render DIR`: one PNG per frame of a run directory (Embree ray casting, ccfr::render),
// optionally a contact sheet and an MP4. Exit codes: 0 done, 2 bad input.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/io/run_json.hpp"
#include "ccfr/render/render_run.hpp"
#include "commands.hpp"
#include "progress.hpp"
#include "run_driver.hpp"

namespace ccfr::app {

namespace {

namespace fs = std::filesystem;

struct RenderCliOptions {
  fs::path dir;
  fs::path out;
  int width = 800;
  int height = 600;
  std::string camera;
  std::string up = "y";
  double fov = 40.0;
  int every = 1;
  int threads = 0;
  int samples = 4;
  int ao = 4;
  double strand_radius = 0.0;
  double point_radius = 0.0;
  bool video = false;
  bool sheet = false;
  bool no_ground = false;
  bool no_shadows = false;
  bool frame_all = false;
  int sheet_frames = 12;
  int sheet_columns = 4;
  double fps = 0.0;
};

int run_render(const RenderCliOptions& o) {
  if (!fs::is_directory(o.dir)) throw Error("'" + o.dir.string() + "' is not a directory");
  set_thread_count(o.threads);
  // run.json is optional: a folder of frames from elsewhere renders too, with default radii and rate.
  const io::RunInfo info = io::read_run_info(o.dir, /*require_run_json=*/false);
  if (info.frames.empty()) throw Error("no frames in '" + (o.dir / "frames").string() + "'");

  render::RunRenderOptions opt;
  opt.out = o.out.empty() ? o.dir / "render" : o.out;
  opt.render.width = o.width;
  opt.render.height = o.height;
  opt.render.samples = o.samples;
  opt.render.ao_samples = o.ao;
  opt.render.shadows = !o.no_shadows;
  opt.render.ground = !o.no_ground;
  opt.render.strand_radius = o.strand_radius;
  opt.render.point_radius = o.point_radius;
  opt.render.offset_hint = info.meta.contact.offset;
  opt.render.up = render::parse_axis(o.up);
  opt.render.fov_deg = o.fov;
  if (!o.camera.empty()) opt.camera = render::parse_camera(o.camera, opt.render.up);
  if (!o.frame_all) opt.frame_exclude = info.obstacles;  // frame the subject, not the floor
  opt.every = o.every;
  opt.sheet = o.sheet;
  opt.sheet_frames = o.sheet_frames;
  opt.sheet_columns = o.sheet_columns;
  opt.video = o.video;
  opt.fps = o.fps > 0 ? o.fps : (info.meta.fps > 0 ? info.meta.fps : 30.0);

  const size_t count = render::select_frames(info.frames.size(), o.every).size();
  std::printf("render %s: %zu of %zu frames at %dx%d, %d threads -> %s\n", o.dir.string().c_str(), count,
              info.frames.size(), o.width, o.height, thread_count(), opt.out.string().c_str());
  std::fflush(stdout);

  ProgressReporter progress("render frame", static_cast<long>(count), 5.0);
  const auto on_frame = [&progress](int done, int, const fs::path& png) {
    progress.update(done, png.filename().string());
  };
  const render::RunRenderSummary s = render::render_frames(info.frames, opt, on_frame);
  progress.finish();

  std::printf(
      "%zu images in %s, %.3f s per frame (camera eye %.4g,%.4g,%.4g target %.4g,%.4g,%.4g fov %.4g; "
      "strand radius %.3g, point radius %.3g)\n",
      s.images.size(), format_duration(progress.elapsed_s()).c_str(), s.seconds_per_frame, s.view.camera.eye.x(),
      s.view.camera.eye.y(), s.view.camera.eye.z(), s.view.camera.target.x(), s.view.camera.target.y(),
      s.view.camera.target.z(), s.view.camera.fov_deg, s.view.strand_radius, s.view.point_radius);
  if (!o.camera.empty())
    std::printf("camera: as given by --camera\n");
  else if (!opt.frame_exclude.empty())
    std::printf("camera: fitted to the objects other than the obstacles (%s); --frame-all fits all of them\n",
                [&] {
                  std::string names;
                  for (const std::string& n : opt.frame_exclude) names += (names.empty() ? "" : ", ") + n;
                  return names;
                }()
                    .c_str());
  if (!s.sheet.empty()) std::printf("contact sheet: %s\n", s.sheet.string().c_str());
  if (!s.video.empty()) std::printf("video: %s\n", s.video.string().c_str());
  if (o.video && s.video.empty()) std::printf("%s\n", s.video_note.c_str());
  std::printf("next: ccfr plot %s\n", shell_quote(o.dir.string()).c_str());
  return 0;
}

}  // namespace

void register_render(CLI::App& app) {
  auto o = std::make_shared<RenderCliOptions>();
  auto* cmd = app.add_subcommand("render",
                                 "Draw the frames of a run directory as PNG images (Embree ray casting); "
                                 "a contact sheet and an MP4 (ffmpeg) on request");
  cmd->add_option("dir", o->dir, "Run directory (holding frames/frame_*.obj)")->required();
  cmd->add_option("--out", o->out, "Output folder (default: DIR/render)");
  cmd->add_option("--width", o->width, "Image width in pixels")->check(CLI::Range(8, 16384))->capture_default_str();
  cmd->add_option("--height", o->height, "Image height in pixels")->check(CLI::Range(8, 16384))->capture_default_str();
  cmd->add_option("--camera", o->camera,
                  "Fixed camera \"eye_x,eye_y,eye_z,target_x,target_y,target_z,fov_deg\" "
                  "(default: fitted to the bounds of all drawn frames)");
  cmd->add_flag("--frame-all", o->frame_all,
                "Fit the camera to every object; by default obstacles (floors, walls) are drawn but left out of "
                "the fit, so the simulated objects fill the picture");
  cmd->add_option("--up", o->up, "Up axis: x, y, z or -x, -y, -z (the floor is drawn below the scene along it)")
      ->capture_default_str();
  cmd->add_option("--fov", o->fov, "Vertical field of view of the fitted camera, degrees")
      ->check(CLI::Range(1.0, 170.0))
      ->capture_default_str();
  cmd->add_option("--every", o->every, "Draw every K-th frame (the last frame is always drawn)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "Worker threads (0: all cores)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--samples", o->samples, "Camera rays per pixel (antialiasing; rounded down to a square)")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  cmd->add_option("--ao", o->ao, "Ambient-occlusion rays per camera ray (0: off)")
      ->check(CLI::Range(0, 64))
      ->capture_default_str();
  cmd->add_option("--strand-radius", o->strand_radius,
                  "Tube radius of strands (default: xi/2 from run.json, else from the segment length)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--point-radius", o->point_radius,
                  "Sphere radius of particles (default: xi/2 from run.json, else from the spacing)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("--no-ground", o->no_ground, "Do not draw the checkered floor");
  cmd->add_flag("--no-shadows", o->no_shadows, "Do not cast shadows from the key light");
  cmd->add_flag("--video", o->video,
                "Also write video.mp4 into the output folder (needs ffmpeg; plays at fps / every)");
  cmd->add_flag("--sheet", o->sheet, "Also write sheet.png into the output folder, a grid of evenly spaced frames");
  cmd->add_option("--sheet-frames", o->sheet_frames, "Frames on the contact sheet")
      ->check(CLI::Range(1, 400))
      ->capture_default_str();
  cmd->add_option("--sheet-columns", o->sheet_columns, "Columns of the contact sheet")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  cmd->add_option("--fps", o->fps,
                  "Frame rate of the frames (default: fps from run.json, else 30); the video plays at fps/every")
      ->check(CLI::PositiveNumber);
  cmd->callback([o] {
    init_logging("warn");
    guarded([o] { return run_render(*o); });
  });
}

}  // namespace ccfr::app
