// `dat` (planar Divide-and-Truncate): the division planes and truncated positions against closed
// forms on hand-built cases, the fallbacks of truncate_against(), the slide DAT keeps where OGC
// stalls, and a scene audited by the exact (CGAL) audit.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "ccfr/geometry/generators.hpp"
#include "ccfr/geometry_exact/audit.hpp"
#include "ccfr/solvers/dat.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "scenes.hpp"
#include "test_support.hpp"
#include "trust_region_cases.hpp"

using namespace ccfr;
using test::Part;

namespace {

constexpr double kXi = 0.01, kR = 0.01;
constexpr double kGp = 0.45;

test::Probe<DivideAndTruncateSolver> probe(const std::vector<Part>& parts) {
  return {test::build_case(parts, kXi, kR), std::make_unique<DivideAndTruncateSolver>()};
}

Part floor_square() { return test::square("floor", Vec3::Zero(), Vec3::UnitX(), Vec3::UnitZ(), 0.2); }
Part particle(const Vec3& p) { return Part{"dot", ObjectKind::particles, {p}}; }

/// The limit a vertex at height `own` above its division plane's partner gets: the plane at the
/// middle of the gap `gap`, the vertex allowed 2γ_p of its way to ξ/2 from it.
double limit_of(double own, double gap) {
  const double bound = own - gap / 2 + kXi / 2;
  return own - 2 * kGp * (own - bound);
}

}  // namespace

TEST(Dat, IsRegistered) {
  auto s = make_contact_solver("dat");
  EXPECT_EQ(s->name(), "dat");
  EXPECT_TRUE(s->clamps_to_radius());
  EXPECT_TRUE(s->guarantees_separation());
}

TEST(Dat, VertexAboveAPlaneKeepsItsTangentialStep) {
  const double h = 0.02;
  // Over one floor triangle, 18 cm from the other's diagonal edge (out of range): one plane.
  auto p = probe({floor_square(), particle(Vec3(0.15, h, -0.1))});
  p.detect();
  const Index v = 4;
  ASSERT_EQ(p.solver->limits(v).size(), 1u);
  for (const DivisionLimit& l : p.solver->limits(v)) {
    EXPECT_NEAR((l.normal - Vec3::UnitY()).norm(), 0.0, 1e-14);  // the normal of a computed closest point
    EXPECT_NEAR(l.limit, limit_of(h, h), 1e-15);                 // 0.0155
  }
  // Down 5 cm and 3 mm along x: only the normal part is cut, at y = 0.0155; x keeps its 3 mm.
  Positions x = p.scene.state.x;
  x[v] += Vec3(0.003, -0.05, 0.0);
  const SolveResult res = p.resolve(x);
  EXPECT_NEAR((x[v] - Vec3(0.153, limit_of(h, h), -0.1)).norm(), 0.0, 1e-15);
  EXPECT_EQ(res.violations_detected, 1);
  EXPECT_EQ(res.violations_remaining, 0);
}

TEST(Dat, AScriptedStepMovesThePlaneAndPushesWhereTheGapIsGone) {
  // The floor is scripted K up in this pass, the particle 2 cm above it. K = 8 mm: the gap along n
  // is 2 cm − K, the plane at its middle, the limit 2γ_p of the way to ξ/2 above it. K = 12 mm: the
  // gap is below ξ, the plane sits ξ/2 above the floor's new height and the particle is pushed to
  // ξ above that, its tangential step kept.
  for (const double k : {0.008, 0.012}) {
    auto p = probe({floor_square(), particle(Vec3(0.15, 0.02, -0.1))});
    p.kinematic.assign(5, Vec3::Zero());
    for (Index v = 0; v < 4; ++v) p.kinematic[v] = Vec3(0, k, 0);
    p.detect();
    ASSERT_EQ(p.solver->limits(4).size(), 1u);
    const double expect = k < 0.01 ? 0.02 - 2 * kGp * (0.02 - ((0.02 + k) / 2 + kXi / 2)) : k + kXi;
    EXPECT_NEAR(p.solver->limits(4)[0].limit, expect, 1e-15) << k;
    Positions x = p.scene.state.x;
    x[4] += Vec3(0.003, -0.001, 0.0);
    p.iteration = 1;
    p.resolve(x);
    EXPECT_NEAR((x[4] - Vec3(0.153, std::max(expect, 0.019), -0.1)).norm(), 0.0, 1e-15) << k;
  }
}

TEST(Dat, ParallelEdgesGetTheMidPlane) {
  const double gap = 0.02;
  const Part lower{"lower", ObjectKind::strand, {Vec3(0, 0, 0), Vec3(0.1, 0, 0)}, {}, {{0, 1}}};
  const Part upper{"upper", ObjectKind::strand, {Vec3(0, gap, 0), Vec3(0.1, gap, 0)}, {}, {{0, 1}}};
  auto p = probe({lower, upper});
  p.detect();
  // Both move 1 cm toward each other and 2 mm along z: they stop 2γ_p of the way to ξ/2 from the
  // plane y = 0.01, z kept.
  Positions x = p.scene.state.x;
  for (Index v = 0; v < 4; ++v) x[v] += Vec3(0, v < 2 ? 0.01 : -0.01, 0.002);
  p.resolve(x);
  const double stop = gap / 2 - kXi / 2;  // each side's way to its bound: 5 mm
  for (Index v = 0; v < 2; ++v) {
    EXPECT_NEAR(x[v].y(), 2 * kGp * stop, 1e-15) << v;
    EXPECT_NEAR(x[v].z(), 0.002, 1e-15) << v;
  }
  for (Index v = 2; v < 4; ++v) EXPECT_NEAR(x[v].y(), gap - 2 * kGp * stop, 1e-15) << v;
}

TEST(Dat, VertexInACornerIsCutByBothPlanes) {
  // Floor y = 0 and wall x = 0, vertex at (0.015, 0.02): two planes, x ≥ 0.01275 and y ≥ 0.0155.
  const Part wall = test::square("wall", Vec3::Zero(), Vec3::UnitY(), Vec3::UnitZ(), 0.2);
  auto p = probe({floor_square(), wall, particle(Vec3(0.015, 0.02, 0.05))});
  p.detect();
  Positions x = p.scene.state.x;
  x[8] += Vec3(-0.01, -0.01, 0.002);
  p.resolve(x);
  EXPECT_NEAR((x[8] - Vec3(limit_of(0.015, 0.015), limit_of(0.02, 0.02), 0.052)).norm(), 0.0, 1e-15);
}

TEST(Dat, ObliquePlanesThatTheSweepsCannotSettleFallBackAlongTheRay) {
  // A wedge of half-angle 2 degrees around +y with its apex at the centre: the sweeps zig-zag
  // between its sides without settling, so the result is pulled back along the ray to the centre.
  const Vec3 c(0, 0, 0);
  const double a = 2.0 * M_PI / 180.0;
  const std::vector<DivisionLimit> limits = {{Vec3(std::cos(a), std::sin(a), 0), 0.0},
                                             {Vec3(-std::cos(a), std::sin(a), 0), 0.0}};
  Vec3 x(0.001, -0.01, 0.0);
  EXPECT_TRUE(DivideAndTruncateSolver::truncate_against(c, limits, 1.0, x));
  for (const auto& l : limits) EXPECT_GE(l.normal.dot(x), l.limit - 1e-18);
  // Both limits pass through the centre and the swept point still crosses one: the ray meets them at c.
  EXPECT_NEAR(x.norm(), 0.0, 1e-15);
  // With room along the ray (one limit below the centre), the ray stops at the first limit reached.
  const std::vector<DivisionLimit> one = {{Vec3::UnitY(), -0.004}};
  Vec3 y(0.0, -0.01, 0.0);
  DivideAndTruncateSolver::truncate_against(c, one, 1.0, y);
  EXPECT_NEAR((y - Vec3(0, -0.004, 0)).norm(), 0.0, 1e-15);
  // The ball: a free step longer than it is scaled onto it.
  Vec3 z(0.03, 0.04, 0.0);
  DivideAndTruncateSolver::truncate_against(c, {}, 0.01, z);
  EXPECT_NEAR((z - Vec3(0.006, 0.008, 0)).norm(), 0.0, 1e-15);
}

TEST(Dat, RestingContactKeepsSlidingWhereOgcStalls) {
  const double speed = 0.5, free_x = speed * 10 / 60.0;
  Simulation dat(test::floor_puck_scene(kXi * (1.0 + 1e-3), speed, "dat"));
  Simulation ogc(test::floor_puck_scene(kXi * (1.0 + 1e-3), speed, "ogc"));
  const Index p = dat.topology().num_vertices() - 1;
  for (int f = 0; f < 10; ++f) {
    EXPECT_EQ(dat.step_frame().violations_remaining, 0) << f;
    ogc.step_frame();
    EXPECT_GE(dat.positions()[p].y(), kXi * (1.0 - 1e-9)) << f;
  }
  EXPECT_GT(dat.positions()[p].x(), 0.8 * free_x);
  EXPECT_LT(ogc.positions()[p].x(), 0.1 * free_x);
}

TEST(Dat, ClothOnASpherePassesTheExactAuditEveryFrame) {
  const test::DropResult r = test::drop_cloth_audited(gen::sphere(0.08, 2), Vec3(0.01, 0.11, 0.02), "dat");
  EXPECT_GT(r.detected, 0) << "the cloth was meant to reach the sphere";
  EXPECT_LT(r.lowest, 0.08);  // the edges hang below the sphere's top
}
