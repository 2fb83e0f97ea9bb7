// A downstream program on the installed package. (1) Builds a scene in code (no YAML): a small
// cloth falls onto a kinematic plane under the CCFR contact solver and stops above it by at least
// the offset. (2) Runs its own contact solver `ground_plane` (ground_plane_solver.cpp, registered
// there) from scene.yaml: the cloth rests at level + ξ; the solver's keys appear in the generated
// reference, and its section is refused under another solver. (3) Writes that scene's run with its
// own output format `csv` (csv_writer.cpp), selected and set up in scene.yaml: its files hold the
// positions of the run's OBJ frames to 9 digits. (4) Runs its own material constraint `tether`
// (tether_constraint.cpp) from tether.yaml: tethered particles hang exactly `length` below their
// rest positions while the untethered ones fall freely.
#include <ccfr/core/error.hpp>
#include <ccfr/core/topology.hpp>
#include <ccfr/geometry/generators.hpp>
#include <ccfr/io/obj.hpp>
#include <ccfr/io/run_recorder.hpp>
#include <ccfr/io/scene_loader.hpp>
#include <ccfr/solvers/simulation.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "csv_writer.hpp"

static int fail(const char* what) {
  std::printf("FAILED: %s\n", what);
  return 1;
}

static int run_own_writer(const std::filesystem::path& work) {
  using namespace ccfr;
  io::LoadedScene loaded = io::load_scene(CONSUMER_SCENE, {"time.frames=2"});
  Simulation sim(std::move(loaded.scene));
  const std::filesystem::path dir = work / "csv_run";
  std::filesystem::remove_all(dir);
  {
    io::RunRecorder rec(dir, sim, loaded.resolved_json, io::make_run_meta(sim, "consumer", {}), 2);
    rec.start();
    for (int f = 1; f <= 2; ++f) rec.record(sim.step_frame());
    rec.finish("completed");
  }
  for (int frame = 0; frame <= 2; ++frame) {
    char obj[32];
    std::snprintf(obj, sizeof obj, "frame_%05d.obj", frame);
    std::string expected;
    for (const Vec3& p : io::read_frame_obj(dir / "frames" / obj).v) expected += csv_line(p, 9);
    std::ifstream in(dir / "csv" / ("frame_" + std::to_string(frame) + ".csv"));
    std::stringstream text;
    text << in.rdbuf();
    if (expected.empty() || text.str() != expected) return fail("csv frame differs from the OBJ frame");
  }
  std::printf("csv: 3 frames written by the downstream output format\n");
  if (io::config_reference_markdown().find("`output.csv.digits`") == std::string::npos)
    return fail("the reference does not list output.csv.digits");
  return 0;
}

static int run_own_solver() {
  using namespace ccfr;
  io::LoadedScene loaded = io::load_scene(CONSUMER_SCENE);
  if (loaded.scene.params.contact.solver != "ground_plane") return fail("solver not selected");
  if (loaded.resolved_json.find("\"friction\": 1") == std::string::npos)
    return fail("run.json lacks the solver's keys");
  const Index n = loaded.scene.topo.num_vertices();
  Simulation sim(std::move(loaded.scene));
  for (int f = 0; f < 30; ++f) sim.step_frame();
  double lo = 1e9, hi = -1e9;
  for (Index v = 0; v < n; ++v) lo = std::min(lo, sim.positions()[v].y()), hi = std::max(hi, sim.positions()[v].y());
  std::printf("ground_plane: cloth between y = %.9f and %.9f (expected -0.19)\n", lo, hi);
  // The cloth started flat at y = 0 and falls 0.2 m in 0.2 s: after 0.5 s it lies flat at level + ξ.
  if (std::abs(lo + 0.19) > 1e-12 || std::abs(hi + 0.19) > 1e-6) return fail("cloth not resting at level + xi");

  if (io::config_reference_markdown().find("`contact.ground_plane.friction`") == std::string::npos)
    return fail("the reference does not list contact.ground_plane.friction");
  const char* other = R"(
contact:
  solver: ccfr
  ground_plane: {level: 0.5}
objects:
  - {name: c, kind: cloth, shape: {type: grid, size: [1, 1], resolution: [2, 2]}}
)";
  try {
    io::load_scene_text(other, "other.yaml", ".");
    return fail("a ground_plane section under solver ccfr was accepted");
  } catch (const Error& e) {
    std::printf("expected error: %s\n", e.what());
    if (std::string(e.what()).find("other.yaml:4") == std::string::npos) return fail("error without file and line");
  }
  try {
    io::load_scene(CONSUMER_SCENE, {"contact.ground_plane.friction=2"});
    return fail("friction 2 was accepted");
  } catch (const Error& e) {
    std::printf("expected error: %s\n", e.what());
  }
  return 0;
}

static int run_own_material() {
  using namespace ccfr;
  io::LoadedScene loaded = io::load_scene(CONSUMER_TETHER_SCENE);
  const Topology& topo = loaded.scene.topo;
  const ObjectInfo hanging = topo.objects[0], falling = topo.objects[1];
  const Positions rest = loaded.scene.state.rest;
  Simulation sim(std::move(loaded.scene));
  Index tethers = -1;
  for (const auto& [name, n] : sim.materials().counts().by_name)
    if (name == "tether") tethers = n;
  if (tethers != hanging.num_vertices()) return fail("the tether batch does not hold the hanging particles");
  for (int f = 0; f < 30; ++f) sim.step_frame();
  double worst = 0.0;
  for (Index v = hanging.vertex_begin; v < hanging.vertex_end; ++v)
    worst = std::max(worst, (sim.positions()[v] - (rest[v] - Vec3(0, 0.03, 0))).norm());
  std::printf("tether: hanging particles %.3g m from rest - 0.03 y\n", worst);
  if (!(worst < 1e-12)) return fail("tethered particles are not hanging at their tether's length");
  // Free fall for 0.5 s: 1.226 m (XPBD's implicit Euler drops a little further).
  for (Index v = falling.vertex_begin; v < falling.vertex_end; ++v)
    if (!(rest[v].y() - sim.positions()[v].y() > 1.2)) return fail("untethered particles did not fall");
  if (io::config_reference_markdown().find("`materials.<material>.tether.length`") == std::string::npos)
    return fail("the reference does not list materials.<material>.tether.length");
  try {
    io::load_scene(CONSUMER_TETHER_SCENE, {"materials.tethered.tether.length=-1"});
    return fail("a negative tether length was accepted");
  } catch (const Error& e) {
    std::printf("expected error: %s\n", e.what());
    if (std::string(e.what()).find("materials.tethered.tether.length") == std::string::npos)
      return fail("error without the key path");
  }
  return 0;
}

int main(int argc, char** argv) {
  using namespace ccfr;
  const auto cloth = gen::grid(0.4, 0.4, 8, 8);
  const auto floor = gen::plane(1.0, 2);
  TopologyBuilder tb;
  tb.add_object("cloth", ObjectKind::cloth, static_cast<Index>(cloth.v.size()), cloth.f);
  tb.add_object("floor", ObjectKind::obstacle, static_cast<Index>(floor.v.size()), floor.f);
  Scene scene;
  scene.topo = tb.finish();
  scene.state.resize(scene.topo.num_vertices());
  Index k = 0;
  for (const auto& p : cloth.v) scene.state.x[k++] = p + Vec3(0, 0.05, 0);
  for (const auto& p : floor.v) scene.state.x[k++] = p;
  for (Index v = 0; v < static_cast<Index>(cloth.v.size()); ++v)
    scene.state.mass[v] = 1e-3, scene.state.inv_mass[v] = 1e3;
  scene.state.rest = scene.state.x_prev = scene.state.x;
  scene.params.objects.resize(2);
  scene.params.time.substeps = 4;
  scene.params.contact.solver = "ccfr";
  scene.params.contact.offset = 0.01;
  Simulation sim(std::move(scene));
  for (int f = 0; f < 30; ++f) sim.step_frame();
  double min_y = 1e9;
  for (Index v = 0; v < static_cast<Index>(cloth.v.size()); ++v) min_y = std::min(min_y, sim.positions()[v].y());
  std::printf("lowest cloth vertex at y = %.6f\n", min_y);
  if (min_y < 0.01 - 1e-9 || min_y > 0.02) return 1;
  if (const int rc = run_own_solver()) return rc;
  if (const int rc = run_own_writer(argc > 1 ? argv[1] : ".")) return rc;
  if (const int rc = run_own_material()) return rc;
  std::printf("consumer ok\n");
  return 0;
}
