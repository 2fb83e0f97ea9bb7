// Every registered contact solver, with no list to maintain: the suite is instantiated from the
// registry, so a new solver runs here once registered. Each runs the floor scene (a particle
// dropped and sliding on a floor) and a small cloth falling onto a floor; every frame is checked
// by the exact penetration audit (geometry_exact, CGAL predicates: an answer independent of the
// solvers' own detection) wherever the solver claims non-penetration.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>

#include "ccfr/core/error.hpp"
#include "ccfr/geometry/generators.hpp"
#include "ccfr/geometry_exact/audit.hpp"
#include "ccfr/solvers/contact_solver.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {

/// A 0.3 m cloth (6 x 6 cells, 0.1 g per vertex) 3 cm above a kinematic floor, ξ = 1 cm.
Scene cloth_on_floor(const std::string& solver) {
  const auto cloth = gen::grid(0.3, 0.3, 6, 6);
  const auto floor = gen::plane(1.0, 2);
  TopologyBuilder tb;
  tb.add_object("cloth", ObjectKind::cloth, static_cast<Index>(cloth.v.size()), cloth.f);
  tb.add_object("floor", ObjectKind::obstacle, static_cast<Index>(floor.v.size()), floor.f);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  Index k = 0;
  for (const auto& p : cloth.v) s.state.x[k++] = p + Vec3(0, 0.03, 0);
  for (const auto& p : floor.v) s.state.x[k++] = p;
  for (Index v = 0; v < static_cast<Index>(cloth.v.size()); ++v) s.state.mass[v] = 1e-4, s.state.inv_mass[v] = 1e4;
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects.resize(2);
  s.params.contact.solver = solver;
  s.params.contact.offset = 0.01;
  s.params.contact.radius = 0.005;
  s.params.time.substeps = 4;
  return s;
}

struct Outcome {
  Index worst_penetrations = 0;                             ///< most audit penetrations over the frames
  double lowest = std::numeric_limits<double>::infinity();  ///< lowest y of the dynamic vertices
  bool guarantees = false;
};

/// Runs `frames` frames, auditing each against frame 0. Baselines may log that violations remain
/// (contact.on_violation: warn); that is their documented behaviour, not a test failure.
Outcome run(Scene scene, int frames) {
  test::ExpectWarnings baselines_may_warn;
  scene.params.contact.on_violation = ViolationPolicy::warn;
  const Topology topo = scene.topo;
  const Positions x0 = scene.state.x;
  const std::vector<double> inv_mass = scene.state.inv_mass;
  exact::PenetrationAudit audit(topo, x0, exact::AuditOptions{scene.params.contact.offset, 1e-6});
  Simulation sim(std::move(scene));
  Outcome o;
  o.guarantees = make_contact_solver(sim.scene().params.contact.solver)->guarantees_separation();
  for (int f = 0; f < frames; ++f) {
    sim.step_frame();
    const auto& x = sim.positions();
    for (Index v = 0; v < static_cast<Index>(x.size()); ++v) {
      EXPECT_TRUE(x[v].allFinite()) << "frame " << f + 1 << " vertex " << v;
      if (inv_mass[v] > 0.0) o.lowest = std::min(o.lowest, x[v].y());
    }
    o.worst_penetrations = std::max(o.worst_penetrations, audit.audit_next(x).penetrations());
  }
  return o;
}

class EveryContactSolver : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryContactSolver, FloorScene) {
  // Dropped from 5 cm while sliding at 0.5 m/s: lands within 10 frames.
  const Outcome o = run(test::floor_puck_scene(0.05, 0.5, GetParam()), 12);
  if (o.guarantees) {
    EXPECT_EQ(o.worst_penetrations, 0) << GetParam();
    EXPECT_GE(o.lowest, 0.01 * (1 - 1e-6)) << GetParam();
    EXPECT_LE(o.lowest, 0.012) << GetParam() << ": the particle should rest on the floor at ξ";
  }
}

TEST_P(EveryContactSolver, ClothScene) {
  const Outcome o = run(cloth_on_floor(GetParam()), 15);
  if (o.guarantees) {
    EXPECT_EQ(o.worst_penetrations, 0) << GetParam();
    EXPECT_GE(o.lowest, 0.01 * (1 - 1e-6)) << GetParam();
    EXPECT_LE(o.lowest, 0.012) << GetParam() << ": the cloth should reach the floor";
  }
}

INSTANTIATE_TEST_SUITE_P(Solvers, EveryContactSolver, ::testing::ValuesIn(registered_contact_solvers()),
                         [](const auto& info) { return info.param; });

// The audit above is not vacuous: a solver with no contact handling lets the cloth through the floor.
TEST(EveryContactSolverAudit, CatchesTheSolverThatDoesNothing) {
  const Outcome o = run(cloth_on_floor("none"), 15);
  EXPECT_FALSE(o.guarantees);
  EXPECT_GT(o.worst_penetrations, 0);
  EXPECT_LT(o.lowest, 0.0);
}

// The registry's own contract, which the scene file and the CLI rely on.
TEST(ContactSolverRegistry, ListsEveryBuiltInAndChecksParameters) {
  const auto names = registered_contact_solvers();
  for (const char* n :
       {"ccfr", "exact_projection", "successive_projection", "post_process", "toi_clamp", "ogc", "dat", "none"})
    EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
  for (const auto& n : names) EXPECT_EQ(make_contact_solver(n)->name(), n);
  // Unknown names list the registered ones; unknown keys list the solver's keys; ranges hold.
  try {
    make_contact_solver("ccfrr");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("toi_clamp"), std::string::npos) << e.what();
  }
  try {
    make_contact_solver("toi_clamp", ParamValues{{"sweeps", 3LL}});
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("scale, max_iterations, touch_tolerance"), std::string::npos) << e.what();
  }
  EXPECT_THROW(make_contact_solver("toi_clamp", ParamValues{{"scale", 1.5}}), Error);
  EXPECT_THROW(make_contact_solver("toi_clamp", ParamValues{{"max_iterations", 2.5}}), Error);
  EXPECT_NO_THROW(make_contact_solver("toi_clamp", ParamValues{{"scale", 1LL}}));  // an integer is a number
  EXPECT_THROW(contact_solvers().add(
                   {"ccfr", "again", {}, [](const ParamValues&) { return std::make_unique<NoContactSolver>(); }}),
               Error);
}

}  // namespace

namespace {

// stats.csv's candidates_total sums the broad-phase pairs of every detection pass of a frame.
// Closed form where every pass sees the same pairs (nothing moves: no gravity, at rest), then the
// bounds of a falling cloth: at least the largest pass, at most the largest pass times the passes.
// Without the kept sub-pair list (collision.reuse_skin = 0), every pass runs the broad phase.
TEST(FrameStatsCandidates, TotalSumsEveryDetectionPass) {
  Scene still = cloth_on_floor("ccfr");
  still.params.time.gravity = Vec3::Zero();
  still.params.collision.reuse_skin = 0.0;
  const int substeps = still.params.time.substeps;
  Simulation at_rest(std::move(still));
  for (int f = 0; f < 3; ++f) {
    const FrameStats fs = at_rest.step_frame();
    ASSERT_GT(fs.candidates, 0) << "the cloth's own neighbouring triangles are candidates";
    EXPECT_GE(fs.outer_iterations, substeps);
    EXPECT_EQ(fs.candidates_total, static_cast<std::int64_t>(fs.candidates) * fs.outer_iterations) << "frame " << f + 1;
    EXPECT_EQ(fs.detections_reused, 0);
  }
  Scene falling_scene = cloth_on_floor("ccfr");
  falling_scene.params.collision.reuse_skin = 0.0;
  Simulation falling(std::move(falling_scene));
  bool varied = false;
  for (int f = 0; f < 15; ++f) {
    const FrameStats fs = falling.step_frame();
    EXPECT_GE(fs.candidates_total, fs.candidates);
    EXPECT_LE(fs.candidates_total, static_cast<std::int64_t>(fs.candidates) * fs.outer_iterations);
    varied |= fs.candidates_total < static_cast<std::int64_t>(fs.candidates) * fs.outer_iterations;
  }
  EXPECT_TRUE(varied) << "the floor comes into reach during the fall: passes differ";
}

// With the kept list (a skin of r), a cloth at rest runs the broad phase once per frame: each
// frame starts a new list (judged by the velocities, which a checkpoint holds), and every later
// pass reuses it and adds no candidates. The frames equal those without the list bit for bit.
TEST(FrameStatsCandidates, ReusedPassesAddNoCandidatesAndChangeNothing) {
  Scene still = cloth_on_floor("ccfr");
  still.params.time.gravity = Vec3::Zero();
  EXPECT_EQ(still.params.collision.reuse_skin, 0.0) << "off by default";
  still.params.collision.reuse_skin = 1.0;
  Scene plain = cloth_on_floor("ccfr");
  plain.params.time.gravity = Vec3::Zero();
  plain.params.collision.reuse_skin = 0.0;
  Simulation kept(std::move(still)), fresh(std::move(plain));
  for (int f = 0; f < 3; ++f) {
    const FrameStats fs = kept.step_frame(), ref = fresh.step_frame();
    EXPECT_EQ(fs.outer_iterations, ref.outer_iterations);
    EXPECT_EQ(fs.detections_reused, fs.outer_iterations - 1) << "frame " << f + 1;
    EXPECT_EQ(fs.candidates_total, fs.candidates) << "frame " << f + 1;
    EXPECT_GE(fs.candidates, ref.candidates) << "the listing pass's boxes are grown by s/2";
    EXPECT_EQ(fs.constraints, ref.constraints);
    EXPECT_EQ(kept.positions(), fresh.positions()) << "frame " << f + 1;
  }
  // A falling cloth (the floor comes into reach) matches too, reusing where the motion allows.
  Scene kept_falling_scene = cloth_on_floor("ccfr");
  kept_falling_scene.params.collision.reuse_skin = 1.0;
  Simulation kept_falling(std::move(kept_falling_scene));
  Scene plain_falling = cloth_on_floor("ccfr");
  plain_falling.params.collision.reuse_skin = 0.0;
  Simulation fresh_falling(std::move(plain_falling));
  for (int f = 0; f < 15; ++f) {
    const FrameStats fs = kept_falling.step_frame(), ref = fresh_falling.step_frame();
    EXPECT_EQ(fs.violations_detected, ref.violations_detected) << "frame " << f + 1;
    ASSERT_EQ(kept_falling.positions(), fresh_falling.positions()) << "frame " << f + 1;
  }
}

// A cloth falling freely far above the floor moves as a whole: after each frame's listing pass
// every pass reuses the list however fast it falls (a common shift brings no pair closer, and the
// floor, at rest, is far), and the frames equal those without the list bit for bit. (Before
// session 19 a pass had to move every vertex by less than s/2: from the fourth frame on, at
// 0.6 m/s, no pass reused.)
TEST(FrameStatsCandidates, FallingAsAWholeKeepsTheList) {
  auto raised = [](double skin) {
    Scene s = cloth_on_floor("ccfr");
    for (Index v = 0; v < s.topo.objects[0].vertex_end; ++v) s.state.x[v].y() += 1.0;  // the cloth
    s.state.rest = s.state.x_prev = s.state.x;
    s.params.collision.reuse_skin = skin;
    return s;
  };
  Simulation kept(raised(1.0)), fresh(raised(0.0));
  for (int f = 0; f < 10; ++f) {
    const FrameStats fs = kept.step_frame(), ref = fresh.step_frame();
    EXPECT_EQ(fs.outer_iterations, ref.outer_iterations);
    EXPECT_EQ(fs.detections_reused, fs.outer_iterations - 1) << "frame " << f + 1;
    ASSERT_EQ(kept.positions(), fresh.positions()) << "frame " << f + 1;
  }
}

}  // namespace
