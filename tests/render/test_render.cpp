// Tests of ccfr::render: images, cameras, Embree rendering of known scenes (coverage against the
// projected area, strands and particles, a stored reference picture) and whole-run rendering.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/render/camera.hpp"
#include "ccfr/render/image.hpp"
#include "ccfr/render/render_run.hpp"
#include "ccfr/render/renderer.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace ccfr;
using namespace ccfr::render;

namespace {

/// A fresh scratch folder per test, removed at the end.
class ScratchDir {
 public:
  ScratchDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() / ("ccfr_render_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

io::Frame frame_from_text(const fs::path& dir, const std::string& text, const std::string& name = "f.obj") {
  const fs::path p = dir / name;
  std::ofstream(p) << text;
  return io::read_frame_obj(p);
}

/// A unit square in the plane z = 0 (two triangles), an object of its own.
std::string square_obj(const std::string& name, double cx, double cy, double half) {
  std::string s = "o " + name + "\n";
  char buf[128];
  const double xs[4] = {cx - half, cx + half, cx + half, cx - half};
  const double ys[4] = {cy - half, cy - half, cy + half, cy + half};
  for (int i = 0; i < 4; ++i) {
    std::snprintf(buf, sizeof buf, "v %.9g %.9g 0\n", xs[i], ys[i]);
    s += buf;
  }
  return s;
}

/// Camera looking down -z at the origin from distance 3.
Camera front_camera() {
  Camera c;
  c.eye = Vec3(0, 0, 3);
  c.target = Vec3::Zero();
  c.fov_deg = 40;
  return c;
}

RenderOptions plain_options(int w, int h) {
  RenderOptions o;
  o.width = w;
  o.height = h;
  o.samples = 16;
  o.ao_samples = 0;
  o.shadows = false;
  o.ground = false;
  return o;
}

double polygon_area(const std::vector<Eigen::Vector2d>& p) {
  double a = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const auto& u = p[i];
    const auto& v = p[(i + 1) % p.size()];
    a += u.x() * v.y() - v.x() * u.y();
  }
  return 0.5 * std::abs(a);
}

/// Number of distinct colours: a blank image has one.
size_t distinct_colors(const Image& img) {
  std::set<std::uint32_t> colors;
  for (size_t i = 0; i < img.rgb.size(); i += 3)
    colors.insert(static_cast<std::uint32_t>(img.rgb[i]) << 16 | static_cast<std::uint32_t>(img.rgb[i + 1]) << 8 |
                  img.rgb[i + 2]);
  return colors.size();
}

/// The reference scene: a folded sheet (two quads at an angle, shaded front and back), a
/// strand, three particles, on the floor, seen by the fitted camera.
std::string reference_scene() {
  return "o sheet\n"
         "v -0.5 0.0 -0.5\nv 0.5 0.0 -0.5\nv 0.5 0.0 0.5\nv -0.5 0.0 0.5\n"
         "v -0.5 0.5 -0.9\nv 0.5 0.5 -0.9\n"
         "f 1 2 3\nf 1 3 4\nf 1 6 2\nf 1 5 6\n"
         "o hair\n"
         "v -0.4 0.1 0.3\nv -0.2 0.3 0.35\nv 0.0 0.4 0.3\nv 0.2 0.45 0.2\nv 0.4 0.5 0.1\n"
         "l 7 8 9 10 11\n"
         "o grains\n"
         "v 0.3 0.1 0.3\nv 0.1 0.1 0.35\nv 0.2 0.25 0.3\n"
         "p 12 13 14\n";
}

}  // namespace

TEST(RenderImage, PngRoundTripResizeAndSheet) {
  ScratchDir dir;
  Image img(8, 6, 10, 20, 30);
  img.pixel(3, 2)[0] = 200;
  write_png(dir.path() / "a.png", img);
  const Image back = read_png(dir.path() / "a.png");
  ASSERT_EQ(back.width, 8);
  ASSERT_EQ(back.height, 6);
  EXPECT_EQ(back.rgb, img.rgb);

  // Halving averages 2x2 blocks exactly.
  Image checker(4, 4);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) checker.pixel(x, y)[0] = ((x + y) % 2) ? 200 : 100;
  const Image half = resize(checker, 2, 2);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 2; ++x) EXPECT_EQ(half.pixel(x, y)[0], 150);

  const std::vector<Image> tiles(5, Image(20, 10, 0, 0, 255));
  const Image sheet = contact_sheet(tiles, {"frame 0", "1", "2", "3", "frame 40"}, 2, 4);
  EXPECT_EQ(sheet.width, 2 * 20 + 3 * 4);
  EXPECT_EQ(sheet.height, 3 * 10 + 4 * 4);
  EXPECT_THROW(contact_sheet(tiles, {"only one"}, 2), Error);

  Image label(60, 20, 0, 0, 0);
  draw_label(label, 0, 0, "frame 12", 1);
  EXPECT_GT(distinct_colors(label), 1u);
  EXPECT_THROW(read_png(dir.path() / "missing.png"), Error);
}

TEST(RenderCamera, ParseAndFit) {
  const Camera c = parse_camera("1, 2, 3, 0,0,0, 35");
  EXPECT_EQ(c.eye, Vec3(1, 2, 3));
  EXPECT_EQ(c.target, Vec3::Zero());
  EXPECT_DOUBLE_EQ(c.fov_deg, 35);
  EXPECT_THROW(parse_camera("1,2,3,0,0,0"), Error);
  EXPECT_THROW(parse_camera("1,2,3,0,0,zero,40"), Error);
  EXPECT_THROW(parse_camera("0,0,0,0,0,0,40"), Error);
  EXPECT_THROW(parse_camera("0,0,1,0,0,0,180"), Error);
  EXPECT_EQ(parse_axis("z"), Vec3::UnitZ());
  EXPECT_EQ(parse_axis("-y"), -Vec3::UnitY());
  EXPECT_THROW(parse_axis("w"), Error);

  // Every corner of the fitted box lands inside the image, and the box fills it in one direction.
  Bounds b;
  b.extend(Vec3(-1, 0, -0.5));
  b.extend(Vec3(2, 0.3, 0.5));
  for (const Vec3& up : {Vec3::UnitY(), Vec3::UnitZ()}) {
    const Camera fit = fit_camera(b, 4.0 / 3.0, up);
    double minx = 1e9, maxx = -1e9, miny = 1e9, maxy = -1e9;
    for (int k = 0; k < 8; ++k) {
      const Vec3 p((k & 1) ? b.hi.x() : b.lo.x(), (k & 2) ? b.hi.y() : b.lo.y(), (k & 4) ? b.hi.z() : b.lo.z());
      const auto px = project(fit, 800, 600, p);
      ASSERT_TRUE(px.has_value());
      minx = std::min(minx, px->x());
      maxx = std::max(maxx, px->x());
      miny = std::min(miny, px->y());
      maxy = std::max(maxy, px->y());
    }
    EXPECT_GE(minx, 0);
    EXPECT_LE(maxx, 800);
    EXPECT_GE(miny, 0);
    EXPECT_LE(maxy, 600);
    EXPECT_GT(std::max((maxx - minx) / 800, (maxy - miny) / 600), 0.6);
  }
  const auto centre = project(front_camera(), 80, 60, Vec3::Zero());
  ASSERT_TRUE(centre.has_value());
  EXPECT_NEAR(centre->x(), 40, 1e-9);
  EXPECT_NEAR(centre->y(), 30, 1e-9);
  EXPECT_FALSE(project(front_camera(), 80, 60, Vec3(0, 0, 5)).has_value());
}

TEST(Render, ImageIsNotBlankAndObjectsCoverTheirProjectedArea) {
  ScratchDir dir;
  // Two squares side by side, facing the camera, one of them a bit further away.
  std::string text = square_obj("left", -0.5, 0.0, 0.3) + "f 1 2 3\nf 1 3 4\n";
  text += square_obj("right", 0.5, 0.1, 0.25) + "f 5 6 7\nf 5 7 8\n";
  const io::Frame frame = frame_from_text(dir.path(), text);
  ASSERT_EQ(frame.objects.size(), 2u);

  const RenderOptions opt = plain_options(160, 120);
  const View view = resolve_view(frame_bounds(frame), frame, opt, front_camera());
  Renderer renderer;
  const RenderResult r = renderer.render(frame, view, opt);
  ASSERT_EQ(r.image.width, 160);
  ASSERT_EQ(r.image.height, 120);
  EXPECT_GT(distinct_colors(r.image), 10u);

  for (size_t o = 0; o < 2; ++o) {
    std::vector<Eigen::Vector2d> poly;
    for (Index v = frame.objects[o].vertex_begin; v < frame.objects[o].vertex_end; ++v) {
      const auto p = project(view.camera, 160, 120, frame.v[static_cast<size_t>(v)]);
      ASSERT_TRUE(p.has_value());
      poly.push_back(*p);
    }
    const double expected = polygon_area(poly);
    // Boundary pixels go either way: allow about half a pixel along the perimeter.
    const double perimeter = 4.0 * std::sqrt(expected);
    EXPECT_NEAR(static_cast<double>(r.coverage[o]), expected, 0.5 * perimeter + 2) << "object " << o;
  }
  // The two objects are drawn in different colours.
  Vec3 mean[2] = {Vec3::Zero(), Vec3::Zero()};
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) {
      const int id = r.object_id[static_cast<size_t>(y) * 160 + x];
      if (id < 0) continue;
      const auto* p = r.image.pixel(x, y);
      mean[id] += Vec3(p[0], p[1], p[2]) / static_cast<double>(r.coverage[static_cast<size_t>(id)]);
    }
  EXPECT_GT((mean[0] - mean[1]).norm(), 40.0);
}

TEST(Render, StrandsAndParticlesAppearWithTheirSize) {
  ScratchDir dir;
  const std::string text =
      "o strand\nv -0.8 0.4 0\nv -0.2 0.4 0\nv 0.4 0.4 0\nl 1 2 3\n"
      "o grains\nv -0.5 -0.3 0\nv 0 -0.3 0\nv 0.5 -0.3 0\np 4 5 6\n";
  const io::Frame frame = frame_from_text(dir.path(), text);
  ASSERT_EQ(frame.lines.size(), 1u);
  ASSERT_EQ(frame.points.size(), 3u);

  RenderOptions opt = plain_options(200, 150);
  opt.strand_radius = 0.02;
  opt.point_radius = 0.06;
  const View view = resolve_view(frame_bounds(frame), frame, opt, front_camera());
  EXPECT_DOUBLE_EQ(view.strand_radius, 0.02);
  EXPECT_DOUBLE_EQ(view.point_radius, 0.06);
  Renderer renderer;
  const RenderResult r = renderer.render(frame, view, opt);

  // World size of a pixel in the plane z = 0 (distance 3 from the camera).
  const double pix = pixel_size_at(view.camera, 150, 3.0);
  const double strand_px = (1.2 + 2 * 0.02) * (2 * 0.02) / (pix * pix);  // capsule, side view
  const double grains_px = 3 * M_PI * 0.06 * 0.06 / (pix * pix);
  EXPECT_NEAR(static_cast<double>(r.coverage[0]), strand_px, 0.25 * strand_px);
  EXPECT_NEAR(static_cast<double>(r.coverage[1]), grains_px, 0.2 * grains_px);

  // Automatic radii are positive and at least about a pixel.
  const RenderOptions auto_opt = plain_options(200, 150);
  const View auto_view = resolve_view(frame_bounds(frame), frame, auto_opt, front_camera());
  EXPECT_GE(auto_view.strand_radius, 0.5 * pix);
  EXPECT_GE(auto_view.point_radius, 0.5 * pix);
  const RenderResult ra = renderer.render(frame, auto_view, auto_opt);
  EXPECT_GT(ra.coverage[0], 0);
  EXPECT_GT(ra.coverage[1], 0);
  // The contact offset, when known, sets the physical thickness.
  RenderOptions hinted = auto_opt;
  hinted.offset_hint = 0.1;
  const View hinted_view = resolve_view(frame_bounds(frame), frame, hinted, front_camera());
  EXPECT_DOUBLE_EQ(hinted_view.point_radius, 0.05);
  EXPECT_DOUBLE_EQ(hinted_view.strand_radius, 0.05);
}

TEST(Render, WrittenFrameRendersEveryObjectAndIsDeterministic) {
  ScratchDir dir;
  // A frame written by the project's own writer: cloth, a strand and particles.
  TopologyBuilder tb;
  tb.add_object("cloth", ObjectKind::cloth, 4, {Vec3i(0, 1, 2), Vec3i(0, 2, 3)});
  tb.add_object("rope", ObjectKind::strand, 4, {}, {}, {{0, 1, 2, 3}});
  tb.add_object("sand", ObjectKind::particles, 2);
  const Topology topo = tb.finish();
  const Positions x = {Vec3(-0.5, 0, -0.5), Vec3(0.5, 0, -0.5),  Vec3(0.5, 0, 0.5), Vec3(-0.5, 0, 0.5),
                       Vec3(-0.4, 0.2, 0),  Vec3(-0.1, 0.25, 0), Vec3(0.2, 0.3, 0), Vec3(0.4, 0.35, 0),
                       Vec3(0.1, 0.1, 0.3), Vec3(-0.2, 0.1, 0.3)};
  io::write_frame_obj(dir.path() / "frame_00000.obj", topo, x);
  const io::Frame frame = io::read_frame_obj(dir.path() / "frame_00000.obj");
  ASSERT_EQ(frame.objects.size(), 3u);

  RenderOptions opt;
  opt.width = 120;
  opt.height = 90;
  const View view = resolve_view(frame_bounds(frame), frame, opt);
  Renderer renderer;
  set_thread_count(1);
  const RenderResult one = renderer.render(frame, view, opt);
  set_thread_count(2);
  const RenderResult two = renderer.render(frame, view, opt);
  set_thread_count(0);
  EXPECT_EQ(one.image.rgb, two.image.rgb);
  for (size_t o = 0; o < 3; ++o) EXPECT_GT(one.coverage[o], 0) << frame.objects[o].name;
  // The floor is visible under a fitted camera.
  EXPECT_NE(std::find(one.object_id.begin(), one.object_id.end(), -2), one.object_id.end());
}

TEST(Render, MatchesStoredReference) {
  ScratchDir dir;
  const io::Frame frame = frame_from_text(dir.path(), reference_scene());
  RenderOptions opt;
  opt.width = 128;
  opt.height = 96;
  const View view = resolve_view(frame_bounds(frame), frame, opt);
  Renderer renderer;
  const Image image = renderer.render(frame, view, opt).image;
  // Compare a 32x24 box-filtered version: edge pixels that flip under a last-bit change of a
  // float are averaged away, while any change of camera, shading or geometry is not.
  const Image small = resize(image, 32, 24);
  const fs::path ref = fs::path(CCFR_SOURCE_DIR) / "tests/data/render/reference_scene_32x24.png";
  if (std::getenv("CCFR_UPDATE_RENDER_REFERENCE") != nullptr) {
    write_png(ref, small);
    write_png(fs::path(CCFR_SOURCE_DIR) / "tests/data/render/reference_scene_full.png", image);
  }
  ASSERT_TRUE(fs::exists(ref)) << "missing " << ref << " (set CCFR_UPDATE_RENDER_REFERENCE=1 to create it)";
  const ImageDifference d = compare(small, read_png(ref));
  EXPECT_LT(d.mean, 1.5);
  EXPECT_LE(d.max, 24);
}

TEST(Render, RejectsBadInput) {
  ScratchDir dir;
  const io::Frame frame = frame_from_text(dir.path(), square_obj("sq", 0, 0, 0.5) + "f 1 2 3\n");
  RenderOptions opt = plain_options(0, 10);
  Renderer renderer;
  const View view = resolve_view(frame_bounds(frame), frame, plain_options(10, 10));
  EXPECT_THROW(renderer.render(frame, view, opt), Error);
  // An empty frame renders background only.
  const io::Frame empty = frame_from_text(dir.path(), "# nothing\n", "empty.obj");
  const RenderOptions small = plain_options(16, 12);
  const RenderResult r = renderer.render(empty, resolve_view(frame_bounds(empty), empty, small), small);
  EXPECT_EQ(std::count(r.object_id.begin(), r.object_id.end(), -1), 16 * 12);
}

TEST(RenderRun, SelectsFramesAndScansBounds) {
  EXPECT_EQ(select_frames(0, 3), std::vector<size_t>{});
  EXPECT_EQ(select_frames(1, 3), (std::vector<size_t>{0}));
  EXPECT_EQ(select_frames(7, 3), (std::vector<size_t>{0, 3, 6}));
  EXPECT_EQ(select_frames(8, 3), (std::vector<size_t>{0, 3, 6, 7}));
  EXPECT_EQ(select_frames(3, 0), (std::vector<size_t>{0, 1, 2}));

  ScratchDir dir;
  const io::Frame frame = frame_from_text(dir.path(), reference_scene());
  const Bounds a = frame_bounds(frame);
  const Bounds b = scan_obj_bounds(dir.path() / "f.obj");
  EXPECT_TRUE(a.lo.isApprox(b.lo));
  EXPECT_TRUE(a.hi.isApprox(b.hi));
  EXPECT_THROW(scan_obj_bounds(dir.path() / "none.obj"), Error);
}

TEST(RenderRun, WritesPngsSheetAndReportsVideo) {
  ScratchDir dir;
  fs::create_directories(dir.path() / "frames");
  std::vector<fs::path> frames;
  for (int i = 0; i < 5; ++i) {
    // A square falling onto the floor.
    const double y = 1.0 - 0.2 * i;
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.obj", i);
    std::string text = "o square\n";
    for (const auto& [x, z] : {std::pair{-0.5, -0.5}, {0.5, -0.5}, {0.5, 0.5}, {-0.5, 0.5}})
      text += "v " + std::to_string(x) + " " + std::to_string(y) + " " + std::to_string(z) + "\n";
    text += "f 1 2 3\nf 1 3 4\n";
    std::ofstream(dir.path() / "frames" / name) << text;
    frames.push_back(dir.path() / "frames" / name);
  }
  RunRenderOptions opt;
  opt.render.width = 64;
  opt.render.height = 48;
  opt.render.samples = 1;
  opt.out = dir.path() / "render";
  opt.every = 3;
  opt.sheet = true;
  opt.sheet_tile_width = 32;
  opt.video = true;
  int calls = 0;
  const RunRenderSummary s = render_frames(frames, opt, [&](int done, int total, const fs::path& png) {
    ++calls;
    EXPECT_EQ(total, 3);
    EXPECT_EQ(done, calls);
    EXPECT_TRUE(fs::exists(png));
  });
  EXPECT_EQ(calls, 3);
  ASSERT_EQ(s.images.size(), 3u);
  EXPECT_EQ(s.images[0].filename(), "frame_00000.png");
  EXPECT_EQ(s.images[1].filename(), "frame_00003.png");
  EXPECT_EQ(s.images[2].filename(), "frame_00004.png");
  EXPECT_GT(s.seconds_per_frame, 0);
  ASSERT_FALSE(s.sheet.empty());
  const Image sheet = read_png(s.sheet);
  EXPECT_EQ(sheet.width, 3 * 32 + 4 * 4);
  EXPECT_EQ(sheet.height, 24 + 2 * 4);
  if (find_program("ffmpeg")) {
    EXPECT_TRUE(fs::exists(s.video)) << s.video_note;
  } else {
    EXPECT_TRUE(s.video.empty());
    EXPECT_NE(s.video_note.find("ffmpeg"), std::string::npos);
  }
  // The camera stays fixed over the run: the fitted view covers the first and the last frame.
  const Image first = read_png(s.images[0]);
  EXPECT_EQ(first.width, 64);
  EXPECT_THROW(render_frames({}, opt), Error);
}

TEST(RenderRun, VideoCallsFfmpegWithConsecutiveFrames) {
  // A stand-in ffmpeg on PATH: records its arguments and the frames it was given, refuses
  // libx264 (as a build without it would), and writes the output file.
  ScratchDir dir;
  const fs::path bin = dir.path() / "bin";
  fs::create_directories(bin);
  {
    std::ofstream script(bin / "ffmpeg");
    script << "#!/bin/sh\n"
              "case \"$*\" in *libx264*) exit 1;; esac\n"
              "echo \"$@\" > '"
           << (dir.path() / "args.txt").string()
           << "'\n"
              "ls \"$(dirname \"$7\")\" > '"
           << (dir.path() / "inputs.txt").string()
           << "'\n"
              "for last; do :; done\n"
              "echo video > \"$last\"\n";
  }
  fs::permissions(bin / "ffmpeg", fs::perms::owner_all);
  const std::string old_path = std::getenv("PATH") ? std::getenv("PATH") : "";
  ::setenv("PATH", (bin.string() + ":" + old_path).c_str(), 1);

  std::vector<fs::path> images;
  for (const int f : {0, 5, 10}) {
    images.push_back(dir.path() / ("frame_0000" + std::to_string(f) + ".png"));
    write_png(images.back(), Image(8, 8, 1, 2, 3));
  }
  std::string message;
  const bool ok = make_video(images, 12.0, dir.path() / "video.mp4", message);
  ::setenv("PATH", old_path.c_str(), 1);
  ASSERT_TRUE(ok) << message;
  EXPECT_TRUE(fs::exists(dir.path() / "video.mp4"));
  std::ifstream args_in(dir.path() / "args.txt");
  const std::string args((std::istreambuf_iterator<char>(args_in)), std::istreambuf_iterator<char>());
  EXPECT_NE(args.find("-framerate 12"), std::string::npos) << args;
  EXPECT_NE(args.find("mpeg4"), std::string::npos) << args;
  std::ifstream inputs_in(dir.path() / "inputs.txt");
  const std::string inputs((std::istreambuf_iterator<char>(inputs_in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(inputs, "000000.png\n000001.png\n000002.png\n");
  // The scratch folder of numbered links is gone.
  for (const auto& e : fs::directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename().string().rfind(".video-", 0), std::string::npos) << e.path();

  // Without ffmpeg on PATH the reason is reported and nothing is written.
  ::setenv("PATH", (dir.path() / "empty").c_str(), 1);
  std::string why;
  EXPECT_FALSE(make_video(images, 12.0, dir.path() / "none.mp4", why));
  ::setenv("PATH", old_path.c_str(), 1);
  EXPECT_NE(why.find("ffmpeg"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir.path() / "none.mp4"));
}
