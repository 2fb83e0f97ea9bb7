// Issue #39, item 6: "no non-finite position, ever". Hanging strands (pinned roots) and a thin comb
// (4 mm teeth, 8 mm thick) driven through them at 1.5 m/s, r = 3 mm, ξ = 2 mm, every substep split
// automatically into pieces of at most 0.9 r. In the dense grid the teeth push strands into the
// rows behind them; the regions of such a vertex can be empty with a nearly antiparallel pair of
// planes, which the exact projection (ccfr's d < 0 path, exact_projection) turned into an infinite
// position at the comb's first contact. Every registered contact solver runs both scenes; the
// exact audit (geometry_exact, CGAL predicates) checks the single row wherever the solver claims
// non-penetration.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/geometry/generators.hpp"
#include "ccfr/geometry_exact/audit.hpp"
#include "ccfr/solvers/contact_solver.hpp"
#include "ccfr/solvers/frame_stats.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {

/// `obstacle` (vertices already placed) and strands of `nv` vertices, `length` m long, 2 g/m,
/// their roots (first vertices, pinned) moved by `root_offset`; stretch compliance 1e-7, bending 0.1.
Scene pinned_strands_by(const char* obstacle_name, const gen::TriMesh& obstacle, const gen::PolylineSet& strands,
                        Index nv, double length, const Vec3& root_offset) {
  TopologyBuilder tb;
  tb.add_object(obstacle_name, ObjectKind::obstacle, static_cast<Index>(obstacle.v.size()), obstacle.f);
  tb.add_object("hair", ObjectKind::strand, static_cast<Index>(strands.v.size()), {}, {}, strands.lines);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  Index k = 0;
  for (const auto& p : obstacle.v) s.state.x[k++] = p;
  for (const auto& p : strands.v) s.state.x[k++] = p + root_offset;
  // Each vertex carries half of each adjacent segment.
  const double seg = length / static_cast<double>(nv - 1), density = 0.002;
  s.params.objects.resize(2);
  PinGroup roots;
  const Index base = static_cast<Index>(obstacle.v.size());
  for (const auto& line : strands.lines)
    for (size_t i = 0; i < line.size(); ++i) {
      const Index v = base + line[i];
      const double m = density * seg * ((i == 0 || i + 1 == line.size()) ? 0.5 : 1.0);
      s.state.mass[v] = m;
      s.state.inv_mass[v] = i == 0 ? 0.0 : 1.0 / m;
      if (i == 0) roots.vertices.push_back(line[i]);
    }
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects[1].pins.push_back(roots);
  s.params.objects[1].material.density = density;
  set_material_key(s.params.objects[1].material, "stretch_compliance", 1e-7);
  set_material_key(s.params.objects[1].material, "bend_compliance", 0.1);
  return s;
}

/// A comb (teeth pointing up, spine below the strand tips) starting at z = -0.15 and moving
/// along +z at 1.5 m/s, and `count` strands of 30 vertices, 0.2 m long, roots pinned at y = 0.2
/// on a square grid of side `spread` (or a row along x) centred at (cx, cz).
Scene comb_through_strands(const std::string& solver, Index count, double spread, bool row, double cx, double cz) {
  auto comb = gen::comb(0.2, 0.008, 0.02, 20, 0.1, 0.004);
  // Rotated 180 degrees about z (teeth up), then translated.
  for (auto& p : comb.v) p = Vec3(-p.x(), -p.y() - 0.01, p.z() - 0.15);
  const Index nv = 30;
  Scene s = pinned_strands_by("comb", comb, gen::curly_strands(count, nv, 0.2, spread, 0.0, 0.0, row), nv, 0.2,
                              Vec3(cx, 0.2, cz));
  s.params.objects[0].motion.velocity = Vec3(0, 0, 1.5);
  s.params.contact.solver = solver;
  s.params.contact.radius = 0.003;
  s.params.contact.offset = 0.002;
  s.params.contact.repulsion_range = 0.0005;
  s.params.contact.stiffness = 1e4;
  s.params.time.fps = 60;
  s.params.time.substeps = 4;
  s.params.time.iterations = 2;
  s.params.time.xpbd_sweeps = 4;
  return s;
}

class CombThroughStrands : public ::testing::TestWithParam<std::string> {};

// 144 strands 1 cm apart: the teeth reach the first row in frame 4 and push it into the next.
// Separation cannot be kept there (the regions of a pushed vertex become empty; baselines and
// region solvers alike may leave violations, contact.on_violation: warn), but every position of
// every frame stays finite. On main, ccfr and exact_projection stopped at frame 5 with
// "non-finite position ... after stage 'contact resolution'".
TEST_P(CombThroughStrands, DenseGridStaysFinite) {
  test::ExpectWarnings may_warn;
  Scene scene = comb_through_strands(GetParam(), 144, 0.11, false, 0.0, 0.0);
  scene.params.contact.on_violation = ViolationPolicy::warn;
  Simulation sim(std::move(scene));
  for (int f = 1; f <= 5; ++f) {
    try {
      sim.step_frame();
    } catch (const NumericalError& e) {
      FAIL() << GetParam() << ": " << e.what();
    } catch (const GuaranteeError& e) {
      // A clear stop is allowed (toi_clamp holds the comb back, then cannot catch up within r).
      EXPECT_NE(std::string(e.what()).find("frame"), std::string::npos);
      return;
    }
    const auto& x = sim.positions();
    for (Index v = 0; v < static_cast<Index>(x.size()); ++v)
      ASSERT_TRUE(x[v].allFinite()) << GetParam() << ": frame " << f << " vertex " << v;
  }
}

// One row of 12 strands, 1 cm apart, in the path of the teeth: every tooth that meets a strand
// pushes it aside or ahead with nothing behind it. The solvers that guarantee separation keep
// every frame clean by the exact audit, and every solver keeps every position finite.
//
// ogc and dat bound or cut each vertex's own step, so a scripted tooth that walks into a strand
// faster than the strand's bound lets it move away leaves the pair inside ξ (docs/methods.md,
// "where each stalls"). Their promise here is the clear stop: under contact.on_violation: auto
// the run stops with a GuaranteeError before writing a violated frame, and every frame before is
// clean.
TEST_P(CombThroughStrands, SingleRowIsAuditClean) {
  test::ExpectWarnings may_warn;
  Scene scene = comb_through_strands(GetParam(), 12, 0.11, true, 0.0, -0.055);
  const bool trust_region = GetParam() == "ogc" || GetParam() == "dat";
  if (trust_region) {
    exact::PenetrationAudit audit(scene.topo, scene.state.x, exact::AuditOptions{scene.params.contact.offset, 1e-6});
    Simulation sim(std::move(scene));
    for (int f = 1; f <= 8; ++f) {
      try {
        sim.step_frame();
      } catch (const GuaranteeError& e) {
        EXPECT_NE(std::string(e.what()).find("violation"), std::string::npos) << e.what();
        return;
      }
      EXPECT_EQ(audit.audit_next(sim.positions()).penetrations(), 0) << GetParam() << " frame " << f;
    }
    return;
  }
  scene.params.contact.on_violation = ViolationPolicy::warn;
  const bool guarantees = make_contact_solver(GetParam())->guarantees_separation();
  exact::PenetrationAudit audit(scene.topo, scene.state.x, exact::AuditOptions{scene.params.contact.offset, 1e-6});
  Simulation sim(std::move(scene));
  Index worst = 0, remaining = 0;
  for (int f = 1; f <= 8; ++f) {
    try {
      remaining = std::max(remaining, sim.step_frame().violations_remaining);
    } catch (const NumericalError& e) {
      FAIL() << GetParam() << ": " << e.what();
    } catch (const GuaranteeError& e) {
      EXPECT_FALSE(guarantees) << GetParam() << ": " << e.what();
      return;
    }
    const auto& x = sim.positions();
    for (Index v = 0; v < static_cast<Index>(x.size()); ++v)
      ASSERT_TRUE(x[v].allFinite()) << GetParam() << ": frame " << f << " vertex " << v;
    worst = std::max(worst, audit.audit_next(x).penetrations());
  }
  if (guarantees) {
    EXPECT_EQ(remaining, 0) << GetParam();
    EXPECT_EQ(worst, 0) << GetParam();
  }
}

INSTANTIATE_TEST_SUITE_P(Solvers, CombThroughStrands, ::testing::ValuesIn(registered_contact_solvers()),
                         [](const auto& info) { return info.param; });

/// The metre-long strands' contact and time stepping: r = 5 mm, ξ = 2 mm, δ = 1 mm, friction
/// 0.3 / 0.2, 60 fps x `substeps` x 2 iterations, 6 sweeps.
void with_strand_contact(Scene& s, const std::string& solver, int substeps) {
  s.params.contact.solver = solver;
  s.params.contact.radius = 0.005;
  s.params.contact.offset = 0.002;
  s.params.contact.repulsion_range = 0.001;
  s.params.contact.friction_static = 0.3;
  s.params.contact.friction_kinetic = 0.2;
  s.params.time.fps = 60;
  s.params.time.substeps = substeps;
  s.params.time.iterations = 2;
  s.params.time.xpbd_sweeps = 6;
}

/// A bar (1.2 x 0.04 x 0.04 m, 12 triangles) spinning about the vertical through its centre at
/// `omega` rad/s, 2 cm above the tips of 60 strands (40 vertices, 1 m long, 2 g/m) that hang in a
/// row 1 m wide, roots pinned at y = 1, 5 cm behind the bar's axis: the bar strikes the lowest
/// vertices of each strand it passes at up to 0.6 omega m/s. r = 5 mm, ξ = 2 mm, 60 fps x 10.
Scene bar_through_strand_tips(const std::string& solver, double omega) {
  auto bar = gen::box(Vec3(1.2, 0.04, 0.04));
  for (auto& p : bar.v) p.y() += 0.02;
  const Index nv = 40;
  Scene s =
      pinned_strands_by("bar", bar, gen::curly_strands(60, nv, 1.0, 1.0, 0.0, 0.0, true), nv, 1.0, Vec3(0, 1.0, 0.05));
  s.params.objects[0].motion.axis = Vec3::UnitY();
  s.params.objects[0].motion.center = Vec3(0, 0.02, 0);
  s.params.objects[0].motion.angular_velocity = omega;
  with_strand_contact(s, solver, 10);
  return s;
}

class StrandTipsStruck : public ::testing::TestWithParam<std::string> {};

// Issue #54: "a strand tip struck by a spinning obstacle: finite, no stop, clean". At 20 rad/s
// the bar meets a tip with another strand's tip a few millimetres ahead of it; the paper's split
// gives the struck vertex half of that gap, less than the bar's step, so its region is empty and
// the bar's face passed over it (main stopped at frame 10 with "a squeeze ... Held by: 'bar'").
// Such a substep is now solved again with contact.momentum's response, which passes the push on
// (Simulation::substep). 20 frames, each audited exactly; the bar's tip covers 0.02 m per
// substep, split into pieces of at most r.
TEST_P(StrandTipsStruck, BySpinningBarRunsCleanWithoutAStop) {
  test::ExpectWarnings may_warn;  // the subdivision of the bar's step is announced
  Scene scene = bar_through_strand_tips(GetParam(), 20.0);
  exact::PenetrationAudit audit(scene.topo, scene.state.x, exact::AuditOptions{scene.params.contact.offset, 1e-6});
  Simulation sim(std::move(scene));
  int redone = 0;
  for (int f = 1; f <= 20; ++f) {
    FrameStats fs;
    ASSERT_NO_THROW(fs = sim.step_frame()) << GetParam() << " frame " << f;
    EXPECT_EQ(fs.violations_remaining, 0) << GetParam() << " frame " << f;
    redone += fs.substeps_redone;
    ASSERT_EQ(audit.audit_next(sim.positions()).penetrations(), 0) << GetParam() << " frame " << f;
  }
  // The strands were struck: some tip moved more than 5 cm from where it hung.
  double farthest = 0.0;
  const auto& x = sim.positions();
  for (Index v = 8; v < static_cast<Index>(x.size()); v += 40)
    farthest = std::max(farthest, (x[v + 39] - Vec3(x[v].x(), 0.0256, x[v].z())).norm());
  EXPECT_GT(farthest, 0.05) << GetParam();
  EXPECT_GT(redone, 0) << GetParam() << ": no substep needed the second solve (the test no longer tests it)";
}

INSTANTIATE_TEST_SUITE_P(RegionSolvers, StrandTipsStruck, ::testing::Values("ccfr", "exact_projection"),
                         [](const auto& info) { return info.param; });

/// The comb: 24 teeth 2 cm wide (0.6 m long, teeth up, a 2.2 m spine 5 cm thick) driven
/// along +z at 2 m/s through 400 strands hanging in a row 2 m wide (5 mm apart: four per tooth),
/// 40 vertices, 1 m long, roots pinned at y = 1; the teeth reach the row in frame 9. r = 5 mm,
/// ξ = 2 mm, 60 fps x `substeps`.
Scene comb_through_a_row(const std::string& solver, int substeps) {
  auto comb = gen::comb(2.2, 0.05, 0.1, 24, 0.6, 0.02);
  for (auto& p : comb.v) p = Vec3(p.x(), -p.y() - 0.15, -p.z() - 0.3);  // turned about x, teeth up
  const Index nv = 40;
  Scene s =
      pinned_strands_by("comb", comb, gen::curly_strands(400, nv, 1.0, 2.0, 0.0, 0.0, true), nv, 1.0, Vec3(0, 1.0, 0));
  s.params.objects[0].motion.velocity = Vec3(0, 0, 2.0);
  with_strand_contact(s, solver, substeps);
  return s;
}

// Issue #54: "strands dragged through a comb at 2 m/s: finite, no stop, clean". At 20 substeps
// (the comb 1.7 mm a substep against r = 5 mm) it runs through and drags the strands, every frame
// audited exactly. At 10 substeps (3.3 mm) ccfr stops in frame 11 before writing it, with "a
// segment through a face ... (the face passed over the vertex)": the clear stop, reported
// here and asserted only to be clean up to it.
TEST_P(StrandTipsStruck, CombAtTwoMetresPerSecondDragsARowOf400Strands) {
  test::ExpectWarnings may_warn;
  for (const int substeps : {20, 10}) {
    Scene scene = comb_through_a_row(GetParam(), substeps);
    exact::PenetrationAudit audit(scene.topo, scene.state.x, exact::AuditOptions{scene.params.contact.offset, 1e-6});
    Simulation sim(std::move(scene));
    int f = 1;
    for (; f <= 14; ++f) {
      FrameStats fs;
      try {
        fs = sim.step_frame();
      } catch (const GuaranteeError& e) {
        EXPECT_EQ(substeps, 10) << GetParam() << " frame " << f << ": " << e.what();
        break;
      }
      EXPECT_EQ(fs.violations_remaining, 0) << GetParam() << " frame " << f;
      ASSERT_EQ(audit.audit_next(sim.positions()).penetrations(), 0) << GetParam() << " frame " << f;
    }
    std::printf("comb at 2 m/s, %d substeps, %s: %d frames clean%s\n", substeps, GetParam().c_str(), f - 1,
                f <= 14 ? " then a clear stop" : "");
    if (substeps != 20) continue;
    // The teeth dragged the strands: some strand's lowest vertex moved more than 5 cm along z.
    double farthest = 0.0;
    const auto& x = sim.positions();
    const Index base = sim.topology().objects[1].vertex_begin;
    for (Index v = base + 39; v < static_cast<Index>(x.size()); v += 40) farthest = std::max(farthest, x[v].z());
    EXPECT_GT(farthest, 0.05) << GetParam();
  }
}

// The guard, the last line of defence, names the frame, the stage, the vertex and its object with
// the vertex's index within it. An infinite inverse mass makes XPBD's weights inf/inf.
TEST(NonFiniteGuard, NamesFrameStageObjectAndVertex) {
  Scene scene = comb_through_strands("ccfr", 2, 0.01, true, 0.0, 0.0);
  const Index comb_vertices = scene.topo.objects[0].vertex_end;
  const Index poisoned = comb_vertices + 30 + 7;  // second strand, its 8th vertex
  scene.state.inv_mass[poisoned] = std::numeric_limits<double>::infinity();
  Simulation sim(std::move(scene));
  try {
    sim.step_frame();
    FAIL() << "no NumericalError";
  } catch (const NumericalError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.frame(), 1);
    EXPECT_EQ(e.stage(), "xpbd");
    EXPECT_EQ(e.object(), "hair");
    const Index local = e.object_vertex();
    EXPECT_EQ(e.vertex(), comb_vertices + local);
    // The first non-finite vertex of the poisoned strand (the lowest index its NaN reached in the
    // sweeps); no constraint joins two strands, so the first strand stays finite.
    EXPECT_GE(local, 30);
    EXPECT_LT(local, 60);
    EXPECT_EQ(what, "non-finite position at frame 1, vertex " + std::to_string(e.vertex()) +
                        " (object 'hair', vertex " + std::to_string(local) + " of the object), after stage 'xpbd'");
  }
}

}  // namespace
