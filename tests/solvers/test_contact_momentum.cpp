// Contact carries momentum (issue #54, item 1): an impact between two free bodies in free space
// conserves their total linear momentum and their angular momentum about the common centre, and
// elastic bodies part again. Independent answer: the momenta before the impact (no external force
// acts, so nothing may change them), measured from the positions and velocities alone.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

#include "ccfr/geometry/generators.hpp"
#include "ccfr/geometry/mass_properties.hpp"
#include "ccfr/geometry_exact/audit.hpp"
#include "ccfr/solvers/rigid_bodies.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {

/// Two soft tet boxes of `size` (cells of size / 6) in zero gravity: `a` of vertex mass m_a at the
/// origin moving at v_a along +x, `b` of vertex mass m_b a `gap` beyond it along x, shifted by
/// `lateral` along y (a glancing impact has angular momentum), moving at v_b.
Scene two_boxes(const std::string& solver, double m_a, double m_b, double v_a, double v_b, double lateral,
                bool momentum = true, int substeps = 10, bool plane_floor = false) {
  const double size = 0.06, gap = 0.004;
  const auto box = gen::tet_box(Vec3(size, size, size), Vec3i(6, 6, 6));
  const gen::TriMesh floor = gen::plane(1.0, 2);
  TopologyBuilder tb;
  tb.add_object("a", ObjectKind::tet_solid, static_cast<Index>(box.v.size()), {}, box.t);
  tb.add_object("b", ObjectKind::tet_solid, static_cast<Index>(box.v.size()), {}, box.t);
  // A generated plane 0.5 m below, as the loader makes `shape: {type: plane}`: far from the pair.
  if (plane_floor) tb.add_object("floor", ObjectKind::obstacle, static_cast<Index>(floor.v.size()), floor.f);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  const Index n = static_cast<Index>(box.v.size());
  for (Index i = 0; i < n; ++i)
    for (Index k = 0; k < 2; ++k) {
      const Index j = i + k * n;
      s.state.x[j] = box.v[i] + (k == 0 ? Vec3::Zero() : Vec3(size + gap, lateral, 0));
      s.state.v[j] = Vec3(k == 0 ? v_a : v_b, 0, 0);
      s.state.mass[j] = k == 0 ? m_a : m_b;
      s.state.inv_mass[j] = 1.0 / s.state.mass[j];
    }
  if (plane_floor)
    for (size_t i = 0; i < floor.v.size(); ++i) s.state.x[2 * n + static_cast<Index>(i)] = floor.v[i] - Vec3(0, 0.5, 0);
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects.resize(2);
  for (auto& o : s.params.objects) {
    set_material_key(o.material, "volume_compliance", 1e-6);
    set_material_key(o.material, "shear_compliance", 1e-5);
  }
  if (plane_floor) {
    s.params.objects.emplace_back().shape.type = AnalyticShape::Type::plane;
    s.params.objects.back().shape.center = Vec3(0, -0.5, 0);
  }
  s.params.contact.solver = solver;
  s.params.contact.radius = 0.004;
  s.params.contact.offset = 0.002;
  s.params.contact.repulsion_range = 0.0;
  s.params.contact.momentum = momentum;
  s.params.time.fps = 60;
  s.params.time.substeps = substeps;
  s.params.time.iterations = 2;
  s.params.time.xpbd_sweeps = 8;
  s.params.time.damping = 0.0;
  s.params.time.gravity = Vec3::Zero();
  return s;
}

struct Momenta {
  Vec3 p = Vec3::Zero();      ///< total linear momentum
  Vec3 l = Vec3::Zero();      ///< angular momentum about the common centre of mass
  double va = 0.0, vb = 0.0;  ///< each body's centre-of-mass velocity along x
};

Momenta momenta(const Simulation& sim) {
  const auto& st = sim.scene().state;
  Momenta m;
  double total = 0.0;
  Vec3 c = Vec3::Zero();
  for (size_t i = 0; i < st.x.size(); ++i) total += st.mass[i], c += st.mass[i] * st.x[i], m.p += st.mass[i] * st.v[i];
  c /= total;
  for (size_t i = 0; i < st.x.size(); ++i) m.l += st.mass[i] * (st.x[i] - c).cross(st.v[i]);
  for (int k = 0; k < 2; ++k) {
    const auto& o = sim.topology().objects[static_cast<size_t>(k)];
    double mk = 0.0, pk = 0.0;
    for (Index v = o.vertex_begin; v < o.vertex_end; ++v) mk += st.mass[v], pk += st.mass[v] * st.v[v].x();
    (k == 0 ? m.va : m.vb) = pk / mk;
  }
  return m;
}

}  // namespace

/// Each test under ccfr and exact_projection; under a compared solver (test::physics_solvers) only
/// the impacts of issue 54's list run, measured for docs/results.md's table, their closed forms
/// not asserted.
class ContactMomentum : public ::testing::TestWithParam<const char*> {
 protected:
  void SetUp() override {
    if (asserted()) return;
    const std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    const std::vector<const char*> with_rigid = test::physics_solvers_with_rigid();
    const bool takes_rigid = std::find_if(with_rigid.begin(), with_rigid.end(), [](const char* s) {
                               return std::string(s) == GetParam();
                             }) != with_rigid.end();
    for (const char* compared : {"TwoSoftSolidsOfUnequalMass", "ByDefaultTwoSoftSolids"})
      if (name.find(compared) != std::string::npos) return;
    for (const char* compared : {"ARigidBallShotIntoAFreeCloth", "TwoRigidBodiesKeep"})
      if (name.find(compared) != std::string::npos && takes_rigid) return;
    GTEST_SKIP() << "measured under the region solvers only";
  }
  static bool asserted() { return test::asserts_closed_form(GetParam()); }
};

TEST_P(ContactMomentum, TwoSoftSolidsOfUnequalMassConserveMomentumThroughAHeadOnImpactAndPart) {
  // a: 343 vertices of 1 g (0.343 kg) at 2 m/s; b: twice as heavy at -0.5 m/s, 4 mm away. Total
  // momentum 0.343 kg m/s; they meet in the first frame. Measured: within 0.05 % (the paper's
  // response, below, ends at -0.19: both bounce off a plane that stands still).
  Simulation sim(two_boxes(GetParam(), 1e-3, 2e-3, 2.0, -0.5, 0.0));
  const Momenta before = momenta(sim);
  for (int f = 1; f <= 12; ++f) {
    const FrameStats fs = sim.step_frame();
    EXPECT_EQ(fs.violations_remaining, 0) << "frame " << f;
    if (asserted()) EXPECT_NEAR(momenta(sim).p.x(), before.p.x(), 0.02 * std::abs(before.p.x())) << "frame " << f;
  }
  const Momenta after = momenta(sim);
  test::report_physics(std::string("head-on soft solids: momentum after 12 frames, ") + GetParam(), before.p.x(),
                       after.p.x(), "kg m/s");
  if (!asserted()) return;
  EXPECT_LT(after.va, 1.0);             // a was stopped by b (it flew at 2 m/s)
  EXPECT_GT(after.vb - after.va, 0.0);  // and they part again: b moves away from a
}

TEST_P(ContactMomentum, BoxesClosingThreeReachesASubstepKeepTheirMomentum) {
  // The same pair closing at 4 m/s, 11.1 mm a substep at 6 substeps, 16.7 at 4 (r = 4 mm): each
  // box's own surface pairs are split at their anchors, so the projection holds a box's followers
  // behind its stopped front and takes their momentum (at 6 and 4 substeps 15.5 and 2.3 % under
  // ccfr, 16.9 and 4.3 % under exact_projection, before the free island got it back). The pair
  // touches nothing else: its momentum may not change.
  for (const int substeps : {6, 5}) {
    Scene scene = two_boxes(GetParam(), 1e-3, 2e-3, 3.0, -1.0, 0.0, true, substeps);
    // The island is translated after its solve: the exact audit at ξ checks every frame.
    exact::PenetrationAudit audit(scene.topo, scene.state.x, exact::AuditOptions{scene.params.contact.offset, 1e-6});
    Simulation sim(std::move(scene));
    const Momenta before = momenta(sim);
    double worst = 0.0;
    for (int f = 1; f <= 12; ++f) {
      const FrameStats fs = sim.step_frame();
      EXPECT_EQ(fs.violations_remaining, 0) << substeps << " substeps, frame " << f;
      EXPECT_EQ(audit.audit_next(sim.positions()).penetrations(), 0) << substeps << " substeps, frame " << f;
      worst = std::max(worst, std::abs(momenta(sim).p.x() - before.p.x()));
    }
    test::report_physics(std::string("head-on soft solids at 4 m/s, ") + std::to_string(substeps) +
                             " substeps: momentum's largest deviation in 12 frames, " + GetParam(),
                         before.p.x(), before.p.x() + worst, "kg m/s");
    EXPECT_LT(worst, 0.02 * std::abs(before.p.x())) << substeps << " substeps";
    EXPECT_GT(momenta(sim).vb - momenta(sim).va, 0.0) << substeps << " substeps";  // they part
  }
}

TEST_P(ContactMomentum, BoxesClosingFastOffCentreKeepTheirLinearAndAngularMomentum) {
  // The fast pair a third of a box off centre (6 substeps): the contact, in frames 1-2, turns both.
  // Linear momentum within 2 % in all 12 frames; angular momentum about the common centre within
  // 5 % after the impact (the glancing test's measure; in free flight afterwards the material
  // sweeps' own drift takes about 1.5 % a frame from these spinning, ringing boxes).
  Scene scene = two_boxes(GetParam(), 1e-3, 2e-3, 3.0, -1.0, 0.02, true, 6);
  exact::PenetrationAudit audit(scene.topo, scene.state.x, exact::AuditOptions{scene.params.contact.offset, 1e-6});
  Simulation sim(std::move(scene));
  const Momenta before = momenta(sim);
  for (int f = 1; f <= 12; ++f) {
    const FrameStats fs = sim.step_frame();
    EXPECT_EQ(fs.violations_remaining, 0) << "frame " << f;
    EXPECT_EQ(audit.audit_next(sim.positions()).penetrations(), 0) << "frame " << f;
    const Momenta now = momenta(sim);
    EXPECT_LT((now.p - before.p).norm(), 0.02 * before.p.norm()) << "frame " << f;
    if (f != 2) continue;
    test::report_physics(
        std::string("off-centre soft solids at 4 m/s, 6 substeps: angular momentum after the impact, ") + GetParam(),
        before.l.z(), now.l.z(), "kg m²/s");
    EXPECT_LT((now.l - before.l).norm(), 0.05 * before.l.norm());
  }
}

TEST_P(ContactMomentum, AGlancingImpactKeepsTheAngularMomentumAboutTheCommonCentre) {
  // The same pair, b a third of a box above a's axis: the impact turns both. The contact lasts
  // frames 1-2. Linear momentum within 2 % in every frame; angular momentum within 5 % after the
  // impact (measured: 3.9 %, lost where the response's every-vertex sweeps pull back a primitive's
  // overshooting vertices off the closest points' line, and in the passes after the first, whose
  // anchors have moved; docs/results.md). The paper's response loses all of it and more.
  for (const bool momentum : {true, false}) {
    Scene s = two_boxes(GetParam(), 1e-3, 2e-3, 2.0, -0.5, 0.02, momentum);
    s.params.contact.free_islands = momentum;  // false: the paper's response and projection alone
    Simulation sim(std::move(s));
    const Momenta before = momenta(sim);
    for (int f = 1; f <= 2; ++f) {
      const FrameStats fs = sim.step_frame();
      EXPECT_EQ(fs.violations_remaining, 0) << "frame " << f;
    }
    const Momenta now = momenta(sim);
    if (momentum)
      test::report_physics(std::string("glancing soft solids: angular momentum after the impact, ") + GetParam(),
                           before.l.z(), now.l.z(), "kg m²/s");
    if (momentum) {
      EXPECT_LT((now.p - before.p).norm(), 0.02 * before.p.norm());
      EXPECT_LT((now.l - before.l).norm(), 0.05 * before.l.norm());
    } else {
      EXPECT_GT((now.l - before.l).norm(), 0.5 * before.l.norm());
    }
  }
}

TEST_P(ContactMomentum, ByDefaultTwoSoftSolidsKeepTheirMomentaThroughAnImpactAndPart) {
  // The head-on and the glancing pair above under the defaults (contact.momentum false): the paper's
  // fixed dividing plane stops both sides of each pair, and the pair, a free island, gets back by
  // one shift and one turn the momentum and angular momentum the projection took. Measured: the
  // momentum kept to the rounding, the angular momentum within 0.1 %; the head-on pair parts at
  // -0.42 and +0.71 m/s (restitution 0.45). A generated plane floor far below (a scene's usual
  // ground) changes nothing: only obstacles colliding through their distance function
  // (contact.analytic_obstacles) reach beyond their mesh, and only they keep the islands off; on
  // 5f0fba8 any generated shape did, and the head-on pair over the floor ended 12 frames with
  // -0.170 kg m/s of its 0.343.
  for (const auto& [lateral, plane_floor] : {std::pair{0.0, false}, std::pair{0.02, false}, std::pair{0.0, true}}) {
    Simulation sim(two_boxes(GetParam(), 1e-3, 2e-3, 2.0, -0.5, lateral, false, 10, plane_floor));
    const Momenta before = momenta(sim);
    for (int f = 1; f <= 12; ++f) {
      const FrameStats fs = sim.step_frame();
      EXPECT_EQ(fs.violations_remaining, 0) << "frame " << f;
      if (asserted())
        EXPECT_NEAR(momenta(sim).p.x(), before.p.x(), 0.02 * std::abs(before.p.x()))
            << "frame " << f << (plane_floor ? ", over a plane floor" : "");
    }
    const Momenta after = momenta(sim);
    const std::string what = lateral != 0.0 ? "glancing soft solids by default: angular momentum after 12 frames, "
                             : plane_floor
                                 ? "head-on soft solids over a plane floor by default: momentum after 12 frames, "
                                 : "head-on soft solids by default: momentum after 12 frames, ";
    if (lateral == 0.0) {
      test::report_physics(what + GetParam(), before.p.x(), after.p.x(), "kg m/s");
      if (!asserted()) continue;
      EXPECT_LT(after.va, 0.0);             // a, at 2 m/s, is thrown back by b, twice as heavy
      EXPECT_GT(after.vb - after.va, 0.0);  // and they part
    } else {
      test::report_physics(what + GetParam(), before.l.z(), after.l.z(), "kg m²/s");
      if (asserted()) EXPECT_LT((after.l - before.l).norm(), 0.005 * before.l.norm());
    }
  }
}

TEST_P(ContactMomentum, TwoSoftSolidsKeepTheirMomentaWhenLaterPassesMoveOnlyTheHeldBack) {
  // The head-on pair under time.continuation: held_back, by default and under contact.momentum:
  // momentum kept to the rounding and parting speeds within 10 % of full passes' (measured: 1.123
  // against 1.130 m/s by default, 1.189 against 1.267 under the momentum response).
  for (const bool momentum : {false, true}) {
    double parting[2] = {0.0, 0.0};
    for (const auto mode : {TimeParams::Continuation::full, TimeParams::Continuation::held_back}) {
      Scene s = two_boxes(GetParam(), 1e-3, 2e-3, 2.0, -0.5, 0.0, momentum);
      s.params.time.continuation = mode;
      Simulation sim(std::move(s));
      const Momenta before = momenta(sim);
      for (int f = 1; f <= 12; ++f) EXPECT_EQ(sim.step_frame().violations_remaining, 0) << "frame " << f;
      EXPECT_NEAR(momenta(sim).p.x(), before.p.x(), 1e-6 * before.p.x());
      parting[mode == TimeParams::Continuation::held_back] = momenta(sim).vb - momenta(sim).va;
    }
    EXPECT_NEAR(parting[1], parting[0], 0.1 * parting[0]) << (momentum ? "contact.momentum" : "by default");
  }
}

TEST_P(ContactMomentum, ByDefaultGrainsFlyingTogetherWithinReachKeepTheirGapsAndSpeeds) {
  // Grains 8 mm apart (ξ = 4 mm, r = 5 mm: each pair is a contact), all at one velocity in zero
  // gravity, 60 fps x 4 substeps: nothing acts on them, so after 0.2 s every gap and velocity is
  // as it was. The paper's split holds each pair's plane at half the gap a pass, so the trailing
  // grain falls behind; the island's restore then gave that loss to the whole island, and on
  // bd714e1 the first case ended 0.2 s 60 mm apart, the rear grain at 0.80 m/s. Inside a free
  // island the planes follow the motion (split_by_motion). Cases: along the line, the lighter
  // grain behind; a row of three across the motion's line; and the paper's split for contrast.
  struct Case {
    Positions x;
    Vec3 v;
    double rear_mass;
  };
  const Case cases[] = {{{Vec3(0, 0, 0), Vec3(0.008, 0, 0)}, Vec3(1, 0, 0), 0.003},
                        {{Vec3(0, 0, 0), Vec3(0.008, 0, 0), Vec3(0.016, 0, 0)}, Vec3(0.8, 0.5, -0.3), 0.01}};
  for (const auto& c : cases) {
    Scene s = test::particle_scene(c.x);
    s.state.mass[0] = c.rear_mass, s.state.inv_mass[0] = 1.0 / c.rear_mass;
    for (auto& v : s.state.v) v = c.v;
    s.params.contact.solver = GetParam();
    s.params.contact.offset = 0.004;
    s.params.contact.repulsion_range = 0.0;
    s.params.time.fps = 60;
    s.params.time.substeps = 4;
    s.params.time.damping = 0.0;
    s.params.time.gravity = Vec3::Zero();
    Simulation sim(std::move(s));
    for (int f = 1; f <= 12; ++f) EXPECT_EQ(sim.step_frame().violations_remaining, 0) << "frame " << f;
    const auto& st = sim.scene().state;
    for (size_t i = 0; i < c.x.size(); ++i) {
      EXPECT_LT((st.v[i] - c.v).norm(), 1e-6 * c.v.norm()) << "grain " << i;
      if (i > 0) EXPECT_NEAR((st.x[i] - st.x[i - 1]).norm(), 0.008, 1e-9) << "grains " << i - 1 << ", " << i;
    }
    if (c.x.size() == 2)
      test::report_physics(
          std::string("two grains flying together 8 mm apart: their gap after 0.2 s by default, ") + GetParam(), 0.008,
          (st.x[1] - st.x[0]).norm(), "m");
  }
  Scene paper = test::particle_scene({Vec3(0, 0, 0), Vec3(0.008, 0, 0)});
  for (auto& v : paper.state.v) v = Vec3(1, 0, 0);
  paper.params.contact.solver = GetParam();
  paper.params.contact.offset = 0.004;
  paper.params.contact.free_islands = false;
  paper.params.time.fps = 60;
  paper.params.time.substeps = 4;
  paper.params.time.gravity = Vec3::Zero();
  Simulation sim(std::move(paper));
  for (int f = 1; f <= 12; ++f) sim.step_frame();
  EXPECT_LT(sim.scene().state.v[0].x(), 0.7);  // the trailing grain is held back at half the gap a pass
}

INSTANTIATE_TEST_SUITE_P(Solvers, ContactMomentum, ::testing::ValuesIn(test::physics_solvers()));

TEST(ContactMomentum, ThePapersResponseStopsBothBodies) {
  // contact.momentum and contact.free_islands false are the paper's response: the pair's dividing
  // plane stands still, so the impact takes the pair's centre-of-mass velocity away (what issue #54
  // measured).
  Scene s = two_boxes("ccfr", 1e-3, 2e-3, 2.0, -0.5, 0.0, false);
  s.params.contact.free_islands = false;
  Simulation sim(std::move(s));
  const Momenta before = momenta(sim);
  for (int f = 1; f <= 6; ++f) sim.step_frame();
  EXPECT_LT(std::abs(momenta(sim).p.x()), 0.6 * std::abs(before.p.x()));
}

namespace {

/// `cards` shells of 9 x 6.3 cm (6 x 4 cells, 1.7 g, stiff in stretch) stacked at rest on a
/// kinematic floor, each ξ + 10 µm above the one below, under gravity: configs/card_stack_xi0_01.yaml
/// cut to a few cards (r = 5 mm, ξ = 10 mm, δ = 1 mm, 4 substeps, 2 iterations).
Scene card_stack(int cards, bool momentum) {
  const gen::TriMesh floor = gen::plane(0.4, 1), card = gen::grid(0.09, 0.063, 6, 4);
  const double xi = 0.01, vertex_mass = 1.7e-3 / static_cast<double>(card.v.size());
  TopologyBuilder tb;
  tb.add_object("table", ObjectKind::obstacle, static_cast<Index>(floor.v.size()), floor.f);
  for (int i = 0; i < cards; ++i)
    tb.add_object("card" + std::to_string(i), ObjectKind::shell, static_cast<Index>(card.v.size()), card.f);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  for (size_t i = 0; i < floor.v.size(); ++i) s.state.x[static_cast<Index>(i)] = floor.v[i];
  for (int k = 0; k < cards; ++k) {
    const auto& o = s.topo.objects[static_cast<size_t>(k) + 1];
    for (Index v = o.vertex_begin; v < o.vertex_end; ++v) {
      s.state.x[v] = card.v[static_cast<size_t>(v - o.vertex_begin)] + Vec3(0, (k + 1) * (xi + 1e-5), 0);
      s.state.mass[v] = vertex_mass;
      s.state.inv_mass[v] = 1.0 / vertex_mass;
    }
  }
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects.resize(static_cast<size_t>(cards) + 1);
  for (auto& o : s.params.objects) {
    set_material_key(o.material, "stretch_compliance", 0.0);
    set_material_key(o.material, "bend_compliance", 1e-4);
  }
  s.params.contact.solver = "ccfr";
  s.params.contact.radius = 0.005;
  s.params.contact.offset = xi;
  s.params.contact.repulsion_range = 0.001;
  s.params.contact.stiffness = 1e4;
  s.params.contact.friction_static = 0.4;
  s.params.contact.friction_kinetic = 0.3;
  s.params.contact.momentum = momentum;
  s.params.time.fps = 60;
  s.params.time.substeps = 4;
  s.params.time.iterations = 2;
  s.params.time.xpbd_sweeps = 8;
  return s;
}

}  // namespace

TEST(ContactMomentum, AStackOfCardsAtRestStaysAtRestInOnePassPerSubstep) {
  // Resting contact exchanges no momentum worth another pass: every card falls by g dt² in its
  // prediction, the floor stops the bottom one and each pair's planes the one above. Before #54's
  // change each card pair asked for another outer iteration (the card below "moved away" in its
  // candidate, although its own planes stopped it), every substep ran time.max_iterations passes,
  // and the 52-card stack cost 36 times its run without momentum. Independent answers: the paper's
  // response (contact.momentum: false) on the same stack, one pass per substep, and where it
  // leaves the cards. The repulsion (δ = 1 mm) lifts the stack by 0.6 mm in the first frames,
  // with and without momentum; from frame 3 on the cards stay put.
  const int cards = 5, frames = 10, settled = 3;
  const double xi = 0.01;
  Positions paper;
  for (const bool momentum : {false, true}) {
    Simulation sim(card_stack(cards, momentum));
    Positions at_rest;
    double drift = 0.0;
    for (int f = 1; f <= frames; ++f) {
      const FrameStats fs = sim.step_frame();
      const std::string run = std::string(momentum ? "with" : "without") + " momentum, frame " + std::to_string(f);
      EXPECT_EQ(fs.violations_remaining, 0) << run;
      EXPECT_EQ(fs.outer_iterations, fs.substeps_run) << run;
      const Positions& x = sim.scene().state.x;
      if (f == settled) at_rest = x;
      for (size_t i = 0; f > settled && i < x.size(); ++i) drift = std::max(drift, (x[i] - at_rest[i]).norm());
    }
    EXPECT_LT(drift, 0.01 * xi) << (momentum ? "with" : "without") << " momentum";
    if (!momentum) {
      paper = sim.scene().state.x;
      continue;
    }
    double apart = 0.0;
    for (size_t i = 0; i < paper.size(); ++i) apart = std::max(apart, (sim.scene().state.x[i] - paper[i]).norm());
    EXPECT_LT(apart, 0.01 * xi);
  }
}

namespace {

/// A rigid ball (radius 5 cm, density 600: 0.314 kg, moment-matched vertex masses and its solid's
/// core, as the loader gives them) `gap` in front of a square cloth (0.5 m, 20 x 20 cells, 0.05 kg,
/// in the plane y = 0), shot at it along -y at `speed`; r = ξ = 5 mm, δ = 1 mm, 60 fps.
/// `pinned`: the cloth hangs from its two top corners (z = 0.25) under gravity along -z. The ball's
/// centre starts at (aim_x, 6.5 cm, 2 mm), off the cloth's vertices and edges.
Scene ball_into_cloth(const std::string& solver, double speed, int substeps, bool pinned, double aim_x = 0.003,
                      int subdivisions = 2) {
  const gen::TriMesh cloth = gen::grid(0.5, 0.5, 20, 20), ball = gen::sphere(0.05, subdivisions);
  TopologyBuilder tb;
  tb.add_object("cloth", ObjectKind::cloth, static_cast<Index>(cloth.v.size()), cloth.f);
  tb.add_object("ball", ObjectKind::rigid, static_cast<Index>(ball.v.size()), ball.f);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  const Index nc = static_cast<Index>(cloth.v.size());
  const double cloth_vertex = 0.05 / static_cast<double>(nc);
  for (Index i = 0; i < nc; ++i) {
    s.state.x[i] = cloth.v[static_cast<size_t>(i)];
    const bool corner = pinned && std::abs(std::abs(s.state.x[i].x()) - 0.25) < 1e-9 && s.state.x[i].z() > 0.249;
    s.state.mass[i] = corner ? 0.0 : cloth_vertex;
    s.state.inv_mass[i] = corner ? 0.0 : 1.0 / cloth_vertex;
  }
  const double rho = 600.0, gap = 0.01;
  test::place_solid(s, ball, nc, rho, Vec3(aim_x, 0.05 + 0.005 + gap, 0.002), Vec3(0, -speed, 0));
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects.resize(2);
  set_material_key(s.params.objects[0].material, "stretch_compliance", 1e-7);
  set_material_key(s.params.objects[0].material, "bend_compliance", 1e-2);
  s.params.objects[1].material.density = rho;
  s.params.contact.solver = solver;
  s.params.contact.radius = 0.005;
  s.params.contact.offset = 0.005;
  s.params.contact.repulsion_range = 0.001;
  s.params.contact.momentum = true;
  s.params.time.fps = 60;
  s.params.time.substeps = substeps;
  s.params.time.iterations = 2;
  s.params.time.xpbd_sweeps = 4;
  s.params.time.damping = 0.0;
  s.params.time.gravity = pinned ? Vec3(0, 0, -9.81) : Vec3::Zero();
  return s;
}

/// Linear momentum of object `k` (its vertices' masses; a rigid body's core moves with its
/// centre of mass, which the vertex masses carry) and its mass with the core.
struct ObjectMomentum {
  Vec3 p = Vec3::Zero();
  double mass = 0.0;
};
ObjectMomentum object_momentum(const Simulation& sim, int k, double solid_mass = 0.0) {
  const auto& st = sim.scene().state;
  const auto& o = sim.topology().objects[static_cast<size_t>(k)];
  ObjectMomentum m;
  Vec3 mv = Vec3::Zero();
  for (Index v = o.vertex_begin; v < o.vertex_end; ++v) m.mass += st.mass[v], mv += st.mass[v] * st.v[v];
  // The vertices' mass-weighted velocity is the centre of mass's: scale to the solid's mass.
  const double total = solid_mass > 0.0 ? solid_mass : m.mass;
  m.p = mv * (total / m.mass);
  m.mass = total;
  return m;
}

}  // namespace

TEST_P(ContactMomentum, ARigidBallShotIntoAFreeClothCarriesItOnWithTheShotsMomentum) {
  // 0.314 kg at 10 m/s into 0.05 kg of cloth in free space: nothing external acts, so the pair's
  // momentum along the shot stays 3.14 kg m/s through the impact, and the ball carries the cloth
  // on (perfectly inelastic: both at 8.6 m/s). The ball covers 4.2 mm a substep (40 substeps),
  // within r. Independent answer: the momentum before the impact. Before the bodies answered the
  // response's impulses (react_bodies), the ball stopped within two frames (-94 %).
  const gen::TriMesh ball = gen::sphere(0.05, 2);
  const double ball_mass = 600.0 * solid_mass_properties(ball.v, ball.f).volume;
  Simulation sim(ball_into_cloth(GetParam(), 10.0, 40, false));
  const double before = object_momentum(sim, 1, ball_mass).p.y();
  double cloth_speed = 0.0, ball_speed = 0.0;
  for (int f = 1; f <= 6; ++f) {
    const FrameStats fs = sim.step_frame();
    EXPECT_EQ(fs.violations_remaining, 0) << "frame " << f;
    const ObjectMomentum c = object_momentum(sim, 0), b = object_momentum(sim, 1, ball_mass);
    if (asserted()) {
      EXPECT_EQ(fs.halted_vertices, 0) << "frame " << f;
      EXPECT_NEAR(c.p.y() + b.p.y(), before, 0.05 * std::abs(before)) << "frame " << f;
    }
    cloth_speed = -c.p.y() / c.mass;
    ball_speed = -b.p.y() / b.mass;
  }
  const double after = object_momentum(sim, 0).p.y() + object_momentum(sim, 1, ball_mass).p.y();
  test::report_physics(std::string("rigid ball into a free cloth: momentum after 6 frames, ") + GetParam(), before,
                       after, "kg m/s");
  if (!asserted()) return;
  const double inelastic = -before / (ball_mass + 0.05);
  EXPECT_GT(ball_speed, 0.8 * inelastic);   // the ball goes on (it stopped dead before)
  EXPECT_GT(cloth_speed, 0.8 * inelastic);  // and carries the cloth with it
}

TEST_P(ContactMomentum, ABallCoveringMoreThanRASubstepStillCarriesTheClothOn) {
  // The ball of the test above at 20 substeps: 8.3 mm a substep, beyond r = 5 mm, so its pose
  // solve needs several passes a substep, and the cloth that wraps it lies against faces the
  // ball leaves as well as faces it comes onto. The split gave such a vertex at most the gap
  // toward the faces that leave, the ball, following the cloth, advanced about a gap a pass, and
  // what its planes held back when the passes ran out was lost: on e146a74 the pair lost 17 % in
  // 6 frames under exact_projection (0.9 % under ccfr, whose passes ran out less often). Those
  // vertices are now carried by the ball's motion where their other planes allow (mark_carried).
  // Independent answer: the momentum before the impact (zero gravity, nothing external).
  const gen::TriMesh ball = gen::sphere(0.05, 2);
  const double ball_mass = 600.0 * solid_mass_properties(ball.v, ball.f).volume;
  Simulation sim(ball_into_cloth(GetParam(), 10.0, 20, false));
  const double before = object_momentum(sim, 1, ball_mass).p.y();
  for (int f = 1; f <= 6; ++f) {
    const FrameStats fs = sim.step_frame();
    EXPECT_EQ(fs.violations_remaining, 0) << "frame " << f;
    const double now = object_momentum(sim, 0).p.y() + object_momentum(sim, 1, ball_mass).p.y();
    EXPECT_NEAR(now, before, 0.02 * std::abs(before)) << "frame " << f;
  }
  const double after = object_momentum(sim, 0).p.y() + object_momentum(sim, 1, ball_mass).p.y();
  test::report_physics(
      std::string("rigid ball into a free cloth, 8.3 mm a substep: momentum after 6 frames, ") + GetParam(), before,
      after, "kg m/s");
}

TEST_P(ContactMomentum, ABallCoveringTwoOrThreeRASubstepKeepsTheMomentumFromEveryStartingPoint) {
  // A 0.31 kg ball of 642 vertices at 10 m/s, at 15 and 10 substeps: 11.1 and 16.7 mm a substep
  // (2.2 and 3.3 r), so its pose solve is cut by the step bound in every pass of the impact, and
  // the cloth it carries turns with it past r. On 8cc6773 such vertices were let go, the ball,
  // wedged among them, stopped in a pass, and over these five starting points the pair lost
  // 14-52 % at 15 substeps and 1-96 % at 10 (ccfr), 13-39 % and 29-94 % (exact_projection). Now
  // the body's own bound is cut until its carried vertices fit, their planes take the room the
  // other side leaves where it ends, and a primitive half carried comes along whole.
  // Independent answer: the momentum before the impact (zero gravity, nothing external).
  const gen::TriMesh ball = gen::sphere(0.05, 3);
  const double ball_mass = 600.0 * solid_mass_properties(ball.v, ball.f).volume;
  for (const int substeps : {15, 10}) {
    double before = 0.0, worst = 0.0, farthest = -1.0;  // the run whose momentum ends farthest from its start
    for (const double aim_x : {0.003, 0.0041, 0.0052, 0.0063, 0.0074}) {
      // At 10 substeps the stretched cloth snaps ahead of the ball at up to 27 m/s in some runs,
      // past the 8 passes x r a substep allows, and is slowed with a warning (clamped_vertices).
      std::optional<test::ExpectWarnings> snap;
      if (substeps == 10) snap.emplace();
      Simulation sim(ball_into_cloth(GetParam(), 10.0, substeps, false, aim_x, 3));
      before = object_momentum(sim, 1, ball_mass).p.y();
      for (int f = 1; f <= 6; ++f) {
        const FrameStats fs = sim.step_frame();
        EXPECT_EQ(fs.violations_remaining, 0) << substeps << " substeps, " << aim_x << ", frame " << f;
        const double now = object_momentum(sim, 0).p.y() + object_momentum(sim, 1, ball_mass).p.y();
        EXPECT_NEAR(now, before, 0.02 * std::abs(before)) << substeps << " substeps, " << aim_x << ", frame " << f;
      }
      const double after = object_momentum(sim, 0).p.y() + object_momentum(sim, 1, ball_mass).p.y();
      if (std::abs(after - before) > farthest) farthest = std::abs(after - before), worst = after;
      // The only warning expected is the cloth's speed cap (no halt, no projector fallback).
      if (test::counting_sink()->warnings > 0)
        EXPECT_NE(test::counting_sink()->last.find("wants to move"), std::string::npos)
            << aim_x << ": " << test::counting_sink()->last;
    }
    test::report_physics(std::string("rigid ball into a free cloth at ") + std::to_string(substeps) +
                             " substeps, the worst of five starting points: momentum after 6 frames, " + GetParam(),
                         before, worst, "kg m/s");
  }
}

namespace {

/// Two rigid icospheres (radius 5 cm, 162 vertices each, moment-matched vertex masses and their
/// solids' cores) in zero gravity: `a` of density 1000 at the origin moving at 2 m/s along +x,
/// `b` of density 2000 a 1 cm gap beyond it along x, shifted by `lateral` along y, at -0.5 m/s.
/// r = 4 mm, ξ = 2 mm, δ = 0.5 mm, 10 substeps.
Scene two_spheres(const std::string& solver, double lateral, bool momentum) {
  const gen::TriMesh ball = gen::sphere(0.05, 2);
  TopologyBuilder tb;
  tb.add_object("a", ObjectKind::rigid, static_cast<Index>(ball.v.size()), ball.f);
  tb.add_object("b", ObjectKind::rigid, static_cast<Index>(ball.v.size()), ball.f);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  const Index n = static_cast<Index>(ball.v.size());
  test::place_solid(s, ball, 0, 1000.0, Vec3::Zero(), Vec3(2.0, 0, 0));
  test::place_solid(s, ball, n, 2000.0, Vec3(0.11, lateral, 0), Vec3(-0.5, 0, 0));
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects.resize(2);
  s.params.objects[0].material.density = 1000.0;
  s.params.objects[1].material.density = 2000.0;
  s.params.contact.solver = solver;
  s.params.contact.radius = 0.004;
  s.params.contact.offset = 0.002;
  s.params.contact.repulsion_range = 0.0005;
  s.params.contact.momentum = momentum;
  s.params.time.fps = 60;
  s.params.time.substeps = 10;
  s.params.time.iterations = 2;
  s.params.time.damping = 0.0;
  s.params.time.gravity = Vec3::Zero();
  return s;
}

/// The pair's linear momentum and its angular momentum about the common centre of mass, each
/// rigid body counted with its core (the solid's mass that no vertex carries, at its centre of
/// mass, where the moment-matched vertex masses are centred), and each body's velocity along x.
Momenta rigid_momenta(const Simulation& sim, const double (&solid)[2]) {
  const auto& st = sim.scene().state;
  struct Body {
    double mv = 0.0;
    Vec3 c = Vec3::Zero(), v = Vec3::Zero();
  } body[2];
  for (int k = 0; k < 2; ++k) {
    const auto& o = sim.topology().objects[static_cast<size_t>(k)];
    for (Index i = o.vertex_begin; i < o.vertex_end; ++i)
      body[k].mv += st.mass[i], body[k].c += st.mass[i] * st.x[i], body[k].v += st.mass[i] * st.v[i];
    body[k].c /= body[k].mv, body[k].v /= body[k].mv;
  }
  const Vec3 centre = (solid[0] * body[0].c + solid[1] * body[1].c) / (solid[0] + solid[1]);
  Momenta m;
  for (int k = 0; k < 2; ++k) {
    const auto& o = sim.topology().objects[static_cast<size_t>(k)];
    for (Index i = o.vertex_begin; i < o.vertex_end; ++i) m.l += st.mass[i] * (st.x[i] - centre).cross(st.v[i]);
    const double core = solid[k] - body[k].mv;
    m.l += core * (body[k].c - centre).cross(body[k].v);
    m.p += solid[k] * body[k].v;
    (k == 0 ? m.va : m.vb) = body[k].v.x();
  }
  return m;
}

}  // namespace

TEST_P(ContactMomentum, TwoRigidBodiesKeepTheirLinearAndAngularMomentumThroughAnImpact) {
  // a (0.52 kg) at 2 m/s, b (twice as heavy) at -0.5 m/s, head on and a third of a radius off
  // centre; they meet in frame 1. Two rigid bodies answer their contacts in their own pose solves,
  // each against planes split at the anchors, so neither pushes the other: on 92cbae8 this pair
  // lost 97 % of its momentum. Touching nothing else, the pair is a free island and gets back
  // what the planes took: linear momentum within 2 % in every frame, angular momentum within 5 %,
  // every frame audited at ξ. (The pair's own push, answer_pairs, is tested below.)
  const gen::TriMesh ball = gen::sphere(0.05, 2);
  const double volume = solid_mass_properties(ball.v, ball.f).volume;
  const double solid[2] = {1000.0 * volume, 2000.0 * volume};
  for (const double lateral : {0.0, 0.035}) {
    Scene scene = two_spheres(GetParam(), lateral, true);
    exact::PenetrationAudit audit(scene.topo, scene.state.x, exact::AuditOptions{scene.params.contact.offset, 1e-6});
    Simulation sim(std::move(scene));
    const Momenta before = rigid_momenta(sim, solid);
    double worst = 0.0;
    for (int f = 1; f <= 8; ++f) {
      const FrameStats fs = sim.step_frame();
      EXPECT_EQ(fs.violations_remaining, 0) << "lateral " << lateral << ", frame " << f;
      EXPECT_EQ(audit.audit_next(sim.positions()).penetrations(), 0) << "lateral " << lateral << ", frame " << f;
      worst = std::max(worst, (rigid_momenta(sim, solid).p - before.p).norm());
    }
    const Momenta after = rigid_momenta(sim, solid);
    const std::string tag = std::string(lateral > 0.0 ? "off-centre" : "head-on") + " rigid spheres: ";
    test::report_physics(tag + "momentum's largest deviation in 8 frames, " + GetParam(), before.p.x(),
                         before.p.x() + worst, "kg m/s");
    if (asserted()) EXPECT_LT(worst, 0.02 * before.p.norm()) << "lateral " << lateral;
    if (asserted()) EXPECT_LT(after.va, 1.0) << "lateral " << lateral;  // a was stopped by b
    if (lateral == 0.0) continue;
    test::report_physics(tag + "angular momentum after 8 frames, " + GetParam(), before.l.z(), after.l.z(), "kg m²/s");
    if (asserted()) EXPECT_LT((after.l - before.l).norm(), 0.05 * before.l.norm());
  }
}

TEST(ContactMomentum, TwoRigidBodiesPushEachOtherWithEqualAndOppositeImpulses) {
  // RigidBodies::answer_pairs on one overlapping contact between two rigid boxes (0.1 m, 8 corner
  // vertices of 0.1 and 0.3 kg), b 3 cm off a's axis so that the push turns both. Independent
  // answers: after the bodies are moved (exactly, by displace()) the contact's closest points are
  // at the offset again, to the rotation's second order; the pair's linear momentum and its
  // angular momentum about the origin, from each body's mass and inertia tensor summed over its
  // vertices, do not change; and the bodies move apart along n.
  const gen::TriMesh box = gen::box(Vec3(0.1, 0.1, 0.1));
  TopologyBuilder tb;
  tb.add_object("a", ObjectKind::rigid, static_cast<Index>(box.v.size()), box.f);
  tb.add_object("b", ObjectKind::rigid, static_cast<Index>(box.v.size()), box.f);
  const Topology topo = tb.finish();
  SimState st;
  st.resize(topo.num_vertices());
  const Index n = static_cast<Index>(box.v.size());
  const Vec3 at_b(0.101, 0.03, 0.0);
  for (Index i = 0; i < n; ++i)
    for (Index k = 0; k < 2; ++k) {
      const Index v = i + k * n;
      st.x[v] = box.v[static_cast<size_t>(i)] + (k == 0 ? Vec3::Zero() : at_b);
      st.mass[v] = k == 0 ? 0.1 : 0.3;
      st.inv_mass[v] = 1.0 / st.mass[v];
    }
  st.rest = st.x_prev = st.x;
  const RigidBodies rigid(topo, st);
  // a's corner (0.05, 0.05, 0.05) against b's -x face (x = 0.051): its closest point there is
  // (0.051, 0.05, 0.05) = 0.3 (0.051, -0.02, 0.05) + 0.7 (0.051, 0.08, 0.05), 1 mm away, 1 mm
  // closer than the 2 mm offset along n = -x (from b to a).
  auto vertex_at = [&](const Vec3& p) {
    for (Index i = 0; i < 2 * n; ++i)
      if ((st.x[i] - p).norm() < 1e-12) return i;
    return Index{-1};
  };
  ContactPair c;
  c.kind = ContactKind::vf;
  c.v = {vertex_at(Vec3(0.05, 0.05, 0.05)), vertex_at(Vec3(0.051, -0.02, 0.05)), vertex_at(Vec3(0.051, 0.08, 0.05)),
         vertex_at(Vec3(0.051, 0.08, -0.05))};
  for (const Index v : c.v) ASSERT_GE(v, 0);
  c.w = {1.0, -0.3, -0.7, 0.0};
  c.n = Vec3(-1, 0, 0);
  c.offset = 0.002;
  c.distance = 0.001;
  auto closest_gap = [&](const Positions& x) {
    Vec3 d = Vec3::Zero();
    for (int k = 0; k < 4; ++k) d += c.w[static_cast<size_t>(k)] * x[c.v[static_cast<size_t>(k)]];
    const Vec3 d0 = [&] {
      Vec3 e = Vec3::Zero();
      for (int k = 0; k < 4; ++k) e += c.w[static_cast<size_t>(k)] * st.x[c.v[static_cast<size_t>(k)]];
      return e;
    }();
    return c.distance - c.offset + c.n.dot(d - d0);
  };
  // Each body's mass, centre and inertia tensor about its centre, from its vertices.
  struct Body {
    double m = 0.0;
    Vec3 c = Vec3::Zero();
    Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
  } body[2];
  for (int k = 0; k < 2; ++k) {
    for (Index i = k * n; i < (k + 1) * n; ++i) body[k].m += st.mass[i], body[k].c += st.mass[i] * st.x[i];
    body[k].c /= body[k].m;
    for (Index i = k * n; i < (k + 1) * n; ++i) {
      const Vec3 r = st.x[i] - body[k].c;
      body[k].inertia += st.mass[i] * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
    }
  }
  std::vector<Vec3> shift, turn;
  ASSERT_EQ(rigid.answer_pairs(st.x, st.x, std::span<const ContactPair>(&c, 1), PairResponse{0.0, 32}, shift, turn), 1);
  Positions moved = st.x;
  rigid.displace(moved, shift, turn);
  // 1 mm closed, to the second order of the exact rotation (θ² |arm| / 2, θ the turn)
  EXPECT_NEAR(closest_gap(moved), 0.0, 1e-5);
  Vec3 p = Vec3::Zero(), l = Vec3::Zero();
  for (int k = 0; k < 2; ++k) {
    p += body[k].m * shift[static_cast<size_t>(k)];
    l += body[k].inertia * turn[static_cast<size_t>(k)] + body[k].m * body[k].c.cross(shift[static_cast<size_t>(k)]);
  }
  EXPECT_LT(p.norm(), 1e-15);
  EXPECT_LT(l.norm(), 1e-16);
  EXPECT_GT(turn[0].norm(), 1e-3);                                   // off centre: the push turns them
  EXPECT_GT(c.n.dot(shift[0] - shift[1]), 0.0);                      // a moves along n, b against it
  EXPECT_NEAR(shift[1].norm() / shift[0].norm(), 1.0 / 3.0, 1e-12);  // by their masses
  // A contact already at its offset, and one within a single body, push nothing.
  c.distance = 0.0025;
  EXPECT_EQ(rigid.answer_pairs(st.x, st.x, std::span<const ContactPair>(&c, 1), PairResponse{0.0, 32}, shift, turn), 0);
  // Within δ = 1 mm of its offset (0.5 mm beyond it) the pair's XPBD repulsion acts on both alike:
  // λ_r = (δ - g) / (w_A + w_B + α̃), w from each body's mass and inertia at the closest points'
  // midpoint, and the gap opens by (w_A + w_B) λ_r; momentum and angular momentum are kept.
  const double delta = 0.001, alpha = 5.0, g = 0.0005;
  const Vec3 mid(0.0505, 0.05, 0.05);
  double w = 0.0;
  for (int k = 0; k < 2; ++k) {
    const Vec3 rn = (mid - body[k].c).cross(c.n);
    w += 1.0 / body[k].m + rn.dot(body[k].inertia.inverse() * rn);
  }
  const double lambda = (delta - g) / (w + alpha);
  std::vector<double> repelled;
  ASSERT_EQ(rigid.answer_pairs(st.x, st.x, std::span<const ContactPair>(&c, 1), PairResponse{0.0, 32, delta, alpha},
                               shift, turn, &repelled),
            1);
  ASSERT_EQ(repelled.size(), 1u);
  EXPECT_NEAR(repelled[0], lambda, 1e-12 * lambda);
  moved = st.x;
  rigid.displace(moved, shift, turn);
  EXPECT_NEAR(closest_gap(moved), g + w * lambda, 1e-7);
  p = l = Vec3::Zero();
  for (int k = 0; k < 2; ++k) {
    p += body[k].m * shift[static_cast<size_t>(k)];
    l += body[k].inertia * turn[static_cast<size_t>(k)] + body[k].m * body[k].c.cross(shift[static_cast<size_t>(k)]);
  }
  EXPECT_LT(p.norm(), 1e-15);
  EXPECT_LT(l.norm(), 1e-16);
  // Beyond δ it does not reach.
  c.distance = 0.0035;
  EXPECT_EQ(rigid.answer_pairs(st.x, st.x, std::span<const ContactPair>(&c, 1), PairResponse{0.0, 32, delta, alpha},
                               shift, turn),
            0);
  c.distance = 0.001;
  c.v = {c.v[0], c.v[0] == 0 ? 1 : 0, 2, 3};
  EXPECT_EQ(rigid.answer_pairs(st.x, st.x, std::span<const ContactPair>(&c, 1), PairResponse{0.0, 32}, shift, turn), 0);
  EXPECT_EQ(shift[0], Vec3::Zero());
}
