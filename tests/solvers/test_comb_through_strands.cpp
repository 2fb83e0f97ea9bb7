// Issue #39, item 6: "no non-finite position, ever". Hanging strands (pinned roots) and a thin comb
// (4 mm teeth, 8 mm thick) driven through them at 1.5 m/s, r = 3 mm, ξ = 2 mm, every substep split
// automatically into pieces of at most 0.9 r. In the dense grid the teeth push strands into the
// rows behind them; the regions of such a vertex can be empty with a nearly antiparallel pair of
// planes, which the exact projection (ccfr's d < 0 path, exact_projection) turned into an infinite
// position at the comb's first contact. Every registered contact solver runs both scenes; the
// exact audit (geometry_exact, CGAL predicates) checks the single row wherever the solver claims
// non-penetration.
#include <gtest/gtest.h>

#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/geometry/generators.hpp"
#include "ccfr/geometry_exact/audit.hpp"
#include "ccfr/solvers/contact_solver.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {

/// A comb (teeth pointing up, spine below the strand tips) starting at z = -0.15 and moving
/// along +z at 1.5 m/s, and `count` strands of 30 vertices, 0.2 m long, roots pinned at y = 0.2
/// on a square grid of side `spread` (or a row along x) centred at (cx, cz).
Scene comb_through_strands(const std::string& solver, Index count, double spread, bool row, double cx, double cz) {
  const auto comb = gen::comb(0.2, 0.008, 0.02, 20, 0.1, 0.004);
  const Index nv = 30;
  const auto strands = gen::curly_strands(count, nv, 0.2, spread, 0.0, 0.0, row);
  TopologyBuilder tb;
  tb.add_object("comb", ObjectKind::obstacle, static_cast<Index>(comb.v.size()), comb.f);
  tb.add_object("hair", ObjectKind::strand, static_cast<Index>(strands.v.size()), {}, {}, strands.lines);
  Scene s;
  s.topo = tb.finish();
  s.state.resize(s.topo.num_vertices());
  Index k = 0;
  // Rotated 180 degrees about z (teeth up), then translated.
  for (const auto& p : comb.v) s.state.x[k++] = Vec3(-p.x(), -p.y() - 0.01, p.z() - 0.15);
  for (const auto& p : strands.v) s.state.x[k++] = p + Vec3(cx, 0.2, cz);
  // 2 g/m: each vertex carries half of each adjacent segment.
  const double seg = 0.2 / (nv - 1), density = 0.002;
  s.params.objects.resize(2);
  PinGroup roots;
  const Index base = static_cast<Index>(comb.v.size());
  for (const auto& line : strands.lines)
    for (size_t i = 0; i < line.size(); ++i) {
      const Index v = base + line[i];
      const double m = density * seg * ((i == 0 || i + 1 == line.size()) ? 0.5 : 1.0);
      s.state.mass[v] = m;
      s.state.inv_mass[v] = i == 0 ? 0.0 : 1.0 / m;
      if (i == 0) roots.vertices.push_back(line[i]);
    }
  s.state.rest = s.state.x_prev = s.state.x;
  s.params.objects[0].motion.velocity = Vec3(0, 0, 1.5);
  s.params.objects[1].pins.push_back(roots);
  s.params.objects[1].material.density = density;
  s.params.objects[1].material.stretch_compliance = 1e-7;
  s.params.objects[1].material.bend_compliance = 0.1;
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
