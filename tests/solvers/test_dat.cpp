// `dat` (planar Divide-and-Truncate): the division planes and truncated positions against closed
// forms on hand-built cases, the fallbacks of truncate_against(), the slide DAT keeps where OGC
// stalls, and a scene audited by the exact (CGAL) audit.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "ccfr/geometry/distance.hpp"
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

namespace {

/// The smallest distance between the vertices, edges and faces of different objects, by brute
/// force over every vertex-face and edge-edge pair (independent of the solver's detection).
double closest_between_objects(const Topology& topo, const Positions& x) {
  double best = std::numeric_limits<double>::infinity();
  auto obj = [&](Index v) { return &topo.object_of_vertex(v); };
  for (Index v = 0; v < topo.num_vertices(); ++v)
    for (const Vec3i& f : topo.faces)
      if (obj(v) != obj(f[0]))
        best = std::min(best, std::sqrt(point_triangle(x[v], x[f[0]], x[f[1]], x[f[2]]).distance_sq));
  for (const auto& a : topo.edges)
    for (const auto& b : topo.edges)
      if (obj(a[0]) != obj(b[0]))
        best = std::min(best, std::sqrt(edge_edge(x[a[0]], x[a[1]], x[b[0]], x[b[1]]).distance_sq));
  return best;
}

}  // namespace

TEST(Dat, SqueezedVertexFromFeasibleAnchorsKeepsEveryPairAtTheOffset) {
  // The card stack's bottom card (configs/card_stack_xi0_001.yaml): a vertex resting at exactly ξ
  // on a fixed 0.4 m table triangle, a slightly tilted movable triangle ξ (1 + 1e-6) above it. The
  // anchors are feasible, yet the table pair's gap along its computed normal, ℓ_A − h_B, reads a
  // few 1e-15 below ξ (the normal's rounding times the table's 0.2 m corners); DAT used to take
  // that for a push and put the vertex's limit past its centre, then the sweeps zig-zagged between
  // the two nearly opposite planes and the ray fallback skipped the limit the centre crossed,
  // leaving the vertex up to 1e-3 ξ inside the table's offset.
  const double xi = 0.001, r = 0.0005, tilt = 0.003;
  int cases = 0;
  for (const double x0 : {-0.045, -0.0283, -0.0121, 0.0047, 0.0196, 0.0321, 0.045})
    for (const double z0 : {-0.0315, -0.0101, 0.0157, 0.0299})
      for (const double dir : {-1.0, 1.0}) {
        const Part table = test::square("table", Vec3::Zero(), Vec3::UnitX(), Vec3::UnitZ(), 0.2);
        // The upper triangle's plane y = y0 + tilt (X − x0), at distance ξ (1 + 1e-6) from the vertex.
        const double y0 = xi + xi * (1.0 + 1e-6) * std::sqrt(1.0 + tilt * tilt);
        auto at = [&](double dx, double dz) { return Vec3(x0 + dx, y0 + tilt * dx, z0 + dz); };
        const Part upper{
            "upper", ObjectKind::cloth, {at(-0.01, -0.01), at(0.01, -0.01), at(0.0, 0.012)}, {Vec3i(0, 1, 2)}};
        test::Probe<DivideAndTruncateSolver> p{test::build_case({table, particle(Vec3(x0, xi, z0)), upper}, xi, r),
                                               std::make_unique<DivideAndTruncateSolver>()};
        const Topology& topo = p.scene.topo;
        ASSERT_GE(closest_between_objects(topo, p.scene.state.x), xi) << "feasible anchors";
        p.detect();
        // The premise of the ray fallback: every centre satisfies its own limits.
        for (Index v = 4; v < 8; ++v)
          for (const DivisionLimit& l : p.solver->limits(v))
            EXPECT_GE(l.normal.dot(p.scene.state.x[v]), l.limit) << v << " " << x0 << " " << z0;
        // Gravity-like candidates: the vertex 0.2 mm down and 0.3 mm along x (toward the upper
        // plane's low side for dir = -1), the upper triangle 0.1 mm down.
        Positions x = p.scene.state.x;
        x[4] += Vec3(0.0003 * dir, -0.0002, 0.0001);
        for (Index v = 5; v < 8; ++v) x[v] += Vec3(0.0, -0.0001, 0.0);
        p.resolve(x);
        EXPECT_GE(closest_between_objects(topo, x), xi * (1.0 - 1e-9)) << x0 << " " << z0 << " " << dir;
        ++cases;
      }
  EXPECT_EQ(cases, 56);
}

TEST(Dat, APairInsideItsOffsetIsPushedOutOneWithinTheAuditToleranceIsNot) {
  // The particle starts 2 cm above the floor (offset ξ = 1 cm) and is then found at height h.
  // Below (1 − debug.audit_tolerance) ξ the limit is the bound ξ itself (a push); within the
  // tolerance the pair is feasible and the limit is the particle's own height (no push, no
  // approach); a degenerate h = ξ exactly is the boundary case of the relaxed limit.
  const double tol = 1e-6;
  for (const double h : {0.5 * kXi, kXi * (1.0 - 2 * tol), kXi * (1.0 - 0.5 * tol), kXi}) {
    auto p = probe({floor_square(), particle(Vec3(0.15, 0.02, -0.1))});
    ASSERT_EQ(p.scene.params.debug.audit_tolerance, tol);
    p.scene.state.x[4].y() = h;
    p.detect();
    ASSERT_EQ(p.solver->limits(4).size(), 1u) << h;
    const double expect = h < kXi * (1.0 - tol) ? kXi : h;
    EXPECT_NEAR(p.solver->limits(4)[0].limit, expect, 1e-14) << h;  // the normal's rounding
    Positions x = p.scene.state.x;
    x[4] += Vec3(0.001, -0.001, 0.0);
    p.resolve(x);
    EXPECT_NEAR((x[4] - Vec3(0.151, expect, -0.1)).norm(), 0.0, 1e-14) << h;
  }
}

TEST(Dat, AFloorSlidingAlongItselfUnderAVertexAtTheOffsetPushesNothing) {
  // A scripted step along the floor's own plane closes nothing along n: the vertex resting at ξ
  // keeps its centre as its limit (within the normal's rounding), whatever the step's length.
  for (const double step : {1e-4, 0.003, 0.009})
    for (const double x0 : {0.0123, 0.15, -0.1731}) {
      auto p = probe({floor_square(), particle(Vec3(x0, kXi, -0.1))});
      p.kinematic.assign(5, Vec3::Zero());
      for (Index v = 0; v < 4; ++v) p.kinematic[v] = Vec3(step, 0, 0);
      p.detect();
      ASSERT_EQ(p.solver->limits(4).size(), 1u);
      const DivisionLimit& l = p.solver->limits(4)[0];
      EXPECT_GE(l.normal.dot(p.scene.state.x[4]), l.limit) << step << " " << x0;
      EXPECT_NEAR(l.limit, kXi, 1e-14) << step << " " << x0;
    }
}

TEST(Dat, APushedLimitTheSweepsCannotSettleIsMetFromTheNearestAllowedPoint) {
  // The centre is 0.1 mm below a pushed limit y ≥ 1 mm (a pair inside its offset), and a plane
  // tilted by 3 mrad leaves a slab of 0.5 µm above it. The sweeps zig-zag between the two; the
  // ray from the centre cannot meet the pushed limit, so it starts at the exact projection of the
  // centre onto both, (0, 1 mm, 0), and the result meets every limit.
  const double a = 0.003;
  const Vec3 c(0.0, 0.0009, 0.0);
  const Vec3 n2(-std::sin(a), -std::cos(a), 0.0);
  const std::vector<DivisionLimit> limits = {{Vec3::UnitY(), 0.001}, {n2, n2.dot(Vec3(0, 0.0010005, 0))}};
  for (const Vec3& step : {Vec3(0.0003, -0.0002, 0.0), Vec3(0.0003, 0.0, 0.0001), Vec3(0.0001, -0.0001, 0.0)}) {
    Vec3 x = c + step;
    DivideAndTruncateSolver::truncate_against(c, limits, 1.0, x);
    for (const DivisionLimit& l : limits) EXPECT_GE(l.normal.dot(x), l.limit - 1e-15) << step.transpose();
    // On the segment from the nearest allowed point to the swept candidate: z keeps its share.
    EXPECT_GE(x.y(), 0.001 - 1e-15);
    EXPECT_LE(x.y(), 0.0010005 + a * 0.0003);
  }
  // An empty intersection (the tilted plane below the pushed one): nothing meets both, the pushed
  // limit is left to the sweeps as before and the result stays finite.
  const std::vector<DivisionLimit> empty = {{Vec3::UnitY(), 0.001}, {n2, n2.dot(Vec3(0, 0.0009, 0))}};
  Vec3 x = c + Vec3(0.0003, -0.0002, 0.0);
  DivideAndTruncateSolver::truncate_against(c, empty, 1.0, x);
  EXPECT_TRUE(x.allFinite());
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
