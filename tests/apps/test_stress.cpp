// Stress scenes (configs/stress/*.yaml) the solvers were never tuned for: an irregular rigid rock,
// high-speed impacts, plates squeezing cloth below its minimum thickness, fast twisting, a cloth
// stack on a mesh obstacle, objects starting closer than xi. Each runs through the ccfr executable
// under ccfr, exact_projection, ogc and dat; every written frame is audited (stride 1). The promise
// checked: either the run completes and every frame is clean, or it stops with exit 1 (a clear
// error in run.json) and every frame written before is clean. OGC and DAT refuse scenes with rigid
// bodies (exit 2, a clear error): that refusal is what is checked there. Independent checks where
// the audit is blind: rigid bodies stay rigid (own Kabsch fit), a cloth that starts inside xi of
// the floor stays above it, a sheet that starts inside xi of another stays on top of it.
// The scanned scenes (configs/scanned/*.yaml: CGAL's data meshes at full resolution, fetched by
// scripts/fetch-scanned-meshes) run the same way, and every rigid body in them stays rigid.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>
#include "cli_support.hpp"

namespace fs = std::filesystem;

namespace {

/// Known gap being fixed elsewhere: pairs closer than xi at frame 0 are excluded for the whole run,
/// so scenes whose objects start inside xi of each other fall through. Flip to false once
/// "initial proximity done right" lands to enable those tests.
constexpr bool kInitialProximityPending = false;

enum class Expect { clean_or_error, error };            // what the run may do
enum class Check { none, rigid, above_floor, on_top };  // independent check over every frame

struct StressCase {
  std::string name;    // test name
  std::string config;  // under configs/stress
  int frames;          // frames to run (bounded for test time)
  std::string extra;   // extra command-line arguments (--set ...)
  Expect expect;
  Check check;
  std::string object;  // rigid: the body; above_floor: the cloth; on_top: the upper sheet
  std::string other;   // on_top: the lower sheet
  bool initial_proximity;
  double min_drop = 0.0;          // rigid: the body's centroid must drop at least this much in frame 1 (m)
  std::string folder = "stress";  // under configs/
};

void PrintTo(const StressCase& c, std::ostream* os) { *os << c.name; }

const std::vector<StressCase>& cases() {
  static const std::vector<StressCase> v = {
      {"rock_on_cloth", "rock_on_cloth.yaml", 20, "", Expect::clean_or_error, Check::rigid, "rock", "", false},
      // Nothing to hit: free flight moves the ball 0.168 m in frame 1.
      {"rigid_free_flight", "rigid_free_flight.yaml", 5, "", Expect::clean_or_error, Check::rigid, "ball", "", false,
       0.16},
      // The ball's bottom starts 0.1 m above the cloth: at >= 10 m/s it reaches the cloth (0.1 - xi =
      // 0.095 m) within frame 1 (free flight would take it 0.168 m), and a cloth can only deflect
      // further. A drop below 0.09 m in frame 1 means the ball was slowed before touching anything.
      {"sphere_shot_10", "sphere_shot.yaml", 12, "", Expect::clean_or_error, Check::rigid, "ball", "", false, 0.09},
      {"sphere_shot_20", "sphere_shot.yaml", 12, "--set objects.ball.velocity=[0,-20,0]", Expect::clean_or_error,
       Check::rigid, "ball", "", false, 0.09},
      {"sphere_shot_30", "sphere_shot.yaml", 12, "--set objects.ball.velocity=[0,-30,0]", Expect::clean_or_error,
       Check::rigid, "ball", "", false, 0.09},
      {"squeeze_one", "squeeze_one.yaml", 30, "", Expect::error, Check::none, "", "", false},
      {"squeeze_stack", "squeeze_stack.yaml", 35, "", Expect::error, Check::none, "", "", false},
      {"twisting_fast_3x", "twisting_fast_3x.yaml", 30, "", Expect::clean_or_error, Check::none, "", "", false},
      {"twisting_fast_10x", "twisting_fast_10x.yaml", 30, "", Expect::clean_or_error, Check::none, "", "", false},
      {"cloth_stack_on_rock", "cloth_stack_on_rock.yaml", 20, "", Expect::clean_or_error, Check::none, "", "", false},
      {"cloth_near_floor", "cloth_near_floor.yaml", 30, "", Expect::clean_or_error, Check::above_floor, "cloth", "",
       true},
      {"sheets_near", "sheets_near.yaml", 30, "", Expect::clean_or_error, Check::on_top, "upper", "lower", true},
      // Passes after a substep's first moving only the held-back vertices (and those around pairs
      // the recount found too close): the same scenes, the same guarantee.
      {"squeeze_one_held_back", "squeeze_one.yaml", 30, "--set time.continuation=held_back", Expect::error, Check::none,
       "", "", false},
      {"twisting_fast_10x_held_back", "twisting_fast_10x.yaml", 30, "--set time.continuation=held_back",
       Expect::clean_or_error, Check::none, "", "", false},
      {"cloth_near_floor_held_back", "cloth_near_floor.yaml", 30, "--set time.continuation=held_back",
       Expect::clean_or_error, Check::above_floor, "cloth", "", true},
      // Scanned meshes at full resolution (rigid: every body listed stays rigid in every frame). The
      // windows cover first contact (the pile's bodies land from frame 6, the knot hits the cloth in
      // frame 2, the elephant the top sheet in frame 1); the audit of 70k-vertex frames takes ~8 s
      // each, so the full runs are measured in docs/performance.md, not here.
      {"scanned_rigid_pile", "rigid_pile.yaml", 10, "", Expect::clean_or_error, Check::rigid,
       "armadillo,bunny,knot,elephant", "", false, 0.0, "scanned"},
      {"scanned_solid_on_cloth", "solid_on_cloth.yaml", 5, "", Expect::clean_or_error, Check::none, "", "", false, 0.0,
       "scanned"},
      {"scanned_rigid_into_cloth_stack", "rigid_into_cloth_stack.yaml", 12, "", Expect::clean_or_error, Check::rigid,
       "elephant", "", false, 0.0, "scanned"},
      {"scanned_cloth_on_spinning_mesh", "cloth_on_spinning_mesh.yaml", 12, "", Expect::clean_or_error, Check::none, "",
       "", false, 0.0, "scanned"},
  };
  return v;
}

int run(const std::string& args, std::string& out) {
  const ccfr::test::CliResult r = ccfr::test::run_ccfr(args);
  out += r.out;
  return r.code;
}
std::string slurp(const fs::path& p) { return ccfr::test::read_text(p); }

/// One frame file: vertices, triangles (0-based, global) and each object's vertex range.
struct Frame {
  std::vector<Eigen::Vector3d> v;
  std::vector<std::array<int, 3>> f;
  std::map<std::string, std::pair<int, int>> objects;  // name -> [begin, end)
  std::map<std::string, std::pair<int, int>> faces;    // name -> [begin, end) of f
};

Frame read_frame(const fs::path& p) {
  Frame fr;
  std::ifstream in(p);
  std::string line, cur;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    if (tag == "o") {
      s >> cur;
      fr.objects[cur] = {int(fr.v.size()), int(fr.v.size())};
      fr.faces[cur] = {int(fr.f.size()), int(fr.f.size())};
    } else if (tag == "v") {
      Eigen::Vector3d x;
      s >> x[0] >> x[1] >> x[2];
      fr.v.push_back(x);
      fr.objects[cur].second = int(fr.v.size());
    } else if (tag == "f") {
      std::array<int, 3> t;
      s >> t[0] >> t[1] >> t[2];
      for (int& i : t) --i;
      fr.f.push_back(t);
      fr.faces[cur].second = int(fr.f.size());
    }
  }
  return fr;
}

std::vector<fs::path> frame_files(const fs::path& out) {
  std::vector<fs::path> v;
  if (fs::exists(out / "frames"))
    for (const auto& e : fs::directory_iterator(out / "frames"))
      if (e.path().extension() == ".obj") v.push_back(e.path());
  std::sort(v.begin(), v.end());
  return v;
}

/// Largest distance of an object's vertices from their best rigid fit to the rest shape (Kabsch,
/// unweighted: rigid bodies spread their mass evenly over the vertices).
double rigid_deviation(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& rest, int begin,
                       int end) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero(), c0 = Eigen::Vector3d::Zero();
  for (int v = begin; v < end; ++v) c += x[v], c0 += rest[v];
  c /= double(end - begin);
  c0 /= double(end - begin);
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (int v = begin; v < end; ++v) h += (x[v] - c) * (rest[v] - c0).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  const Eigen::Matrix3d r = svd.matrixU() * d * svd.matrixV().transpose();
  double worst = 0.0;
  for (int v = begin; v < end; ++v) worst = std::max(worst, (r * (rest[v] - c0) + c - x[v]).norm());
  return worst;
}

/// Vertices of `upper` that lie below the surface of `lower` (the triangle of `lower` whose xz
/// projection contains the vertex gives the height). Vertices outside lower's footprint don't count.
int vertices_below(const Frame& fr, const std::string& upper, const std::string& lower, double& worst_depth) {
  const auto [ub, ue] = fr.objects.at(upper);
  const auto [fb, fe] = fr.faces.at(lower);
  int below = 0;
  worst_depth = 0.0;
  for (int v = ub; v < ue; ++v) {
    const Eigen::Vector3d& p = fr.v[v];
    for (int t = fb; t < fe; ++t) {
      const Eigen::Vector3d &a = fr.v[fr.f[t][0]], &b = fr.v[fr.f[t][1]], &c = fr.v[fr.f[t][2]];
      const double det = (b.x() - a.x()) * (c.z() - a.z()) - (c.x() - a.x()) * (b.z() - a.z());
      if (std::abs(det) < 1e-15) continue;
      const double l1 = ((p.x() - a.x()) * (c.z() - a.z()) - (c.x() - a.x()) * (p.z() - a.z())) / det;
      const double l2 = ((b.x() - a.x()) * (p.z() - a.z()) - (p.x() - a.x()) * (b.z() - a.z())) / det;
      if (l1 < 0 || l2 < 0 || l1 + l2 > 1) continue;
      const double h = a.y() + l1 * (b.y() - a.y()) + l2 * (c.y() - a.y());
      if (p.y() < h) {
        ++below;
        worst_depth = std::max(worst_depth, h - p.y());
      }
      break;
    }
  }
  return below;
}

/// Smallest min/xi over the audit's per-frame lines ("frame tri_isect seg_cross close min_dist min/xi").
double audit_min_ratio(const std::string& audit) {
  double best = std::numeric_limits<double>::infinity();
  std::istringstream in(audit);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    long frame;
    int a, b, c;
    std::string dist, ratio;
    if (!(s >> frame >> a >> b >> c >> dist >> ratio)) continue;
    try {
      best = std::min(best, std::stod(ratio));
    } catch (...) {
    }
  }
  return best;
}

std::string run_status(const fs::path& out) {
  const std::string j = slurp(out / "run.json");
  const auto k = j.find("\"status\"");
  if (k == std::string::npos) return "?";
  const auto q0 = j.find('"', j.find(':', k) + 1);
  const auto q1 = j.find('"', q0 + 1);
  return j.substr(q0 + 1, q1 - q0 - 1);
}

}  // namespace

class StressRun : public ::testing::TestWithParam<std::tuple<StressCase, std::string>> {};

TEST_P(StressRun, EveryWrittenFrameIsClean) {
  const auto& [sc, solver] = GetParam();
  if (sc.initial_proximity && kInitialProximityPending) GTEST_SKIP() << "pending: initial proximity";
  const fs::path cfg = fs::path(CCFR_SOURCE_DIR) / "configs" / sc.folder / sc.config;
  if (sc.folder == "scanned" && !fs::exists(cfg.parent_path() / "meshes" / "bunny00.off"))
    GTEST_SKIP() << "the scanned meshes are not fetched (scripts/fetch-scanned-meshes)";
  const fs::path out = ccfr::test::scratch_path("stress_" + sc.name + "_" + solver);
  fs::remove_all(out);
  std::string log;
  const auto t0 = std::chrono::steady_clock::now();
  const int code = run("run " + cfg.string() + " --solver " + solver + " --frames " + std::to_string(sc.frames) +
                           " --out " + out.string() + " --log-level warn " + sc.extra,
                       log);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto files = frame_files(out);
  const int simulated = std::max<int>(0, int(files.size()) - 1);
  const std::string status = fs::exists(out / "run.json") ? run_status(out) : "(no run.json)";

  std::string audit;
  // A run stopped by the guarantee did not complete: its frames are audited with --partial.
  const int audit_code =
      files.empty() ? -1 : run("audit " + out.string() + " --stride 1" + (code == 1 ? " --partial" : ""), audit);
  const double min_ratio = audit_min_ratio(audit);
  // One line per run for the report.
  std::cout << "[stress] " << sc.name << " " << solver << ": exit " << code << ", frames " << simulated << "/"
            << sc.frames << ", s/frame " << (simulated > 0 ? wall / simulated : 0.0) << ", audit " << audit_code
            << ", min/xi " << min_ratio << ", status: " << status << std::endl;

  // OGC and DAT bound each vertex's step on its own, which would deform a rigid body: they refuse
  // rigid objects before the run starts (docs/methods.md), naming the body.
  if ((solver == "ogc" || solver == "dat") && sc.check == Check::rigid) {
    EXPECT_EQ(code, 2) << log;
    EXPECT_NE(log.find("rigid object '"), std::string::npos) << log;
    EXPECT_NE(log.find("is not supported"), std::string::npos) << log;
    EXPECT_TRUE(files.empty()) << "a refused scene wrote frames";
    if (!::testing::Test::HasFailure()) fs::remove_all(out);
    return;
  }
  ASSERT_TRUE(code == 0 || code == 1) << "exit " << code << " is neither completed (0) nor a clean stop (1)\n" << log;
  ASSERT_FALSE(files.empty()) << "no frame written\n" << log;
  if (code == 1) {
    EXPECT_EQ(status.rfind("failed: ", 0), 0u) << "exit 1 without a 'failed: ...' status in run.json: " << status;
    EXPECT_EQ(status.find("non-finite"), std::string::npos) << "stopped on non-finite positions: " << status;
  } else {
    EXPECT_EQ(status, "completed");
    EXPECT_EQ(simulated, sc.frames);
  }
  if (sc.expect == Expect::error)
    EXPECT_EQ(code, 1) << "the plates close below the minimum thickness: the run must stop\n" << log;
  EXPECT_EQ(audit_code, 0) << audit.substr(audit.size() > 6000 ? audit.size() - 6000 : 0);

  if (sc.check == Check::none) return;
  const Frame rest = read_frame(files.front());
  std::vector<std::string> bodies;  // `object` may list several, comma-separated
  for (std::string::size_type at = 0; at <= sc.object.size();) {
    const auto comma = std::min(sc.object.find(',', at), sc.object.size());
    bodies.push_back(sc.object.substr(at, comma - at));
    at = comma + 1;
  }
  for (const auto& b : bodies) ASSERT_TRUE(rest.objects.count(b)) << b;
  if (sc.min_drop > 0.0 && files.size() > 1) {
    const Frame first = read_frame(files[1]);
    const auto [b, e] = rest.objects.at(sc.object);
    double drop = 0.0;
    for (int v = b; v < e; ++v) drop += rest.v[v].y() - first.v[v].y();
    drop /= double(e - b);
    EXPECT_GE(drop, sc.min_drop) << sc.object << " dropped only " << drop << " m in frame 1 (free flight: "
                                 << "initial speed / fps + g / (2 fps^2)); it was slowed before touching anything";
  }
  for (const auto& file : files) {  // stops at the first failing frame
    const Frame fr = read_frame(file);
    ASSERT_EQ(fr.v.size(), rest.v.size()) << file;
    const auto [b, e] = fr.objects.at(bodies.front());
    if (sc.check == Check::rigid) {
      bool deformed = false;
      for (const auto& body : bodies) {
        const auto [bb, be] = fr.objects.at(body);
        const double dev = rigid_deviation(fr.v, rest.v, bb, be);
        if (!(dev < 1e-6)) {
          ADD_FAILURE() << body << " deformed in " << file.filename() << ": Kabsch deviation " << dev << " m";
          deformed = true;
          break;
        }
      }
      if (deformed) break;
    } else if (sc.check == Check::above_floor) {
      double lo = std::numeric_limits<double>::infinity();
      for (int v = b; v < e; ++v) lo = std::min(lo, fr.v[v].y());
      if (!(lo > 0.0)) {
        ADD_FAILURE() << sc.object << " below the floor (y = 0) in " << file.filename() << ": min y " << lo;
        break;
      }
    } else if (sc.check == Check::on_top) {
      double depth = 0.0;
      const int n = vertices_below(fr, sc.object, sc.other, depth);
      if (n != 0) {
        ADD_FAILURE() << n << " vertices of " << sc.object << " below " << sc.other << " in " << file.filename()
                      << " (deepest " << depth << " m)";
        break;
      }
    }
  }
  if (!::testing::Test::HasFailure()) fs::remove_all(out);
}

INSTANTIATE_TEST_SUITE_P(Stress, StressRun,
                         ::testing::Combine(::testing::ValuesIn(cases()),
                                            ::testing::Values("ccfr", "exact_projection", "ogc", "dat")),
                         [](const ::testing::TestParamInfo<std::tuple<StressCase, std::string>>& info) {
                           return std::get<0>(info.param).name + "_" + std::get<1>(info.param);
                         });
