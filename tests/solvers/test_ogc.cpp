// `ogc` (Offset Geometric Contact's conservative bounds): the per-vertex bound b_v against closed
// forms on hand-built cases, the truncation and re-detection rules, bad parameters, and scenes
// audited by the exact (CGAL) audit.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "ccfr/core/error.hpp"
#include "ccfr/geometry/generators.hpp"
#include "ccfr/geometry_exact/audit.hpp"
#include "ccfr/solvers/ogc.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "scenes.hpp"
#include "test_support.hpp"
#include "trust_region_cases.hpp"

using namespace ccfr;
using test::Part;

namespace {

constexpr double kXi = 0.01, kR = 0.01;  // detection range ξ + 2r = 0.03
constexpr double kGp = 0.45;             // the default γ_p

test::Probe<OffsetGeometricContactSolver> probe(const std::vector<Part>& parts, TrustRegionParams p = {}) {
  return {test::build_case(parts, kXi, kR), std::make_unique<OffsetGeometricContactSolver>(p)};
}

Part floor_square() { return test::square("floor", Vec3::Zero(), Vec3::UnitX(), Vec3::UnitZ(), 0.2); }
Part particle(const Vec3& p) { return Part{"dot", ObjectKind::particles, {p}}; }

}  // namespace

TEST(Ogc, IsRegisteredWithThePapersDefaults) {
  auto s = make_contact_solver("ogc");
  EXPECT_EQ(s->name(), "ogc");
  EXPECT_TRUE(s->clamps_to_radius());
  EXPECT_TRUE(s->guarantees_separation());
  const auto& spec = contact_solvers().at("ogc");
  ASSERT_EQ(spec.params.size(), 3u);
  EXPECT_EQ(std::get<double>(spec.params[0].default_value), 0.45);                 // γ_p: the toolkit's 2γ_p = 0.9
  EXPECT_EQ(std::get<double>(spec.params[1].default_value), 0.01);                 // γ_e
  EXPECT_THROW(make_contact_solver("ogc", ParamValues{{"gamma_p", 0.5}}), Error);  // two sides would use 100 %
  EXPECT_THROW(make_contact_solver("ogc", ParamValues{{"gamma_e", -0.1}}), Error);
  EXPECT_THROW(make_contact_solver("ogc", ParamValues{{"query_radius", -1.0}}), Error);
}

TEST(Ogc, VertexAboveAPlaneGetsGammaTimesItsGapBeyondTheOffset) {
  const double h = 0.02;
  auto p = probe({floor_square(), particle(Vec3(0.05, h, 0.07))});
  p.detect();
  const Index v = 4;
  EXPECT_NEAR(p.solver->bounds()[v], kGp * (h - kXi), 1e-15);
  // A step of 6 cm down and sideways: truncated to b_v along its own direction.
  Positions x = p.scene.state.x;
  const Vec3 step(0.03, -0.05, 0.01);
  x[v] += step;
  const SolveResult res = p.resolve(x);
  const Vec3 expect = p.scene.state.x[v] + kGp * (h - kXi) * step.normalized();
  EXPECT_NEAR((x[v] - expect).norm(), 0.0, 1e-15);
  EXPECT_EQ(res.violations_detected, 1);  // truncated
  EXPECT_EQ(res.bounded_vertices, 1);     // 1 of 1 > γ_e: re-detect, another pass
  EXPECT_EQ(res.violations_remaining, 0);
  // A step within the bound is left alone.
  Positions y = p.scene.state.x;
  y[v] += Vec3(0.001, -0.002, 0.0);
  const Vec3 kept = y[v];
  EXPECT_EQ(p.resolve(y).violations_detected, 0);
  EXPECT_EQ(y[v], kept);
}

TEST(Ogc, ParallelEdgesShareOneBoundFromTheirDegenerateClosestPoints) {
  // Two parallel strand segments 2 cm apart: every point of one is a closest point of the other.
  const double gap = 0.02;
  const Part lower{"lower", ObjectKind::strand, {Vec3(0, 0, 0), Vec3(0.1, 0, 0)}, {}, {{0, 1}}};
  const Part upper{"upper", ObjectKind::strand, {Vec3(0, gap, 0), Vec3(0.1, gap, 0)}, {}, {{0, 1}}};
  auto p = probe({lower, upper});
  p.detect();
  for (Index v = 0; v < 4; ++v) EXPECT_NEAR(p.solver->bounds()[v], kGp * (gap - kXi), 1e-15) << v;
  // Both move straight at each other by 1 cm: each stops after γ_p (d − ξ), leaving ξ + 0.1 (d − ξ).
  Positions x = p.scene.state.x;
  for (Index v = 0; v < 2; ++v) x[v].y() += 0.01;
  for (Index v = 2; v < 4; ++v) x[v].y() -= 0.01;
  p.resolve(x);
  EXPECT_NEAR(x[2].y() - x[0].y(), kXi + (1.0 - 2.0 * kGp) * (gap - kXi), 1e-15);
}

TEST(Ogc, VertexInACornerTakesTheNearerFace) {
  // Floor y = 0 and wall x = 0; the vertex is 1.5 cm from the wall and 2 cm above the floor.
  const Part wall = test::square("wall", Vec3::Zero(), Vec3::UnitY(), Vec3::UnitZ(), 0.2);
  auto p = probe({floor_square(), wall, particle(Vec3(0.015, 0.02, 0.05))});
  p.detect();
  EXPECT_NEAR(p.solver->bounds()[8], kGp * (0.015 - kXi), 1e-15);
}

TEST(Ogc, NoNeighbourWithinTheQueryRadiusGivesTheQueryRadiusBound) {
  // Alone: γ_p (r_q − ξ) with r_q = ξ + 2r by default, or the r_q given.
  auto far = probe({floor_square(), particle(Vec3(0.05, 0.5, 0.0))});
  far.detect();
  EXPECT_NEAR(far.solver->query_radius(), kXi + 2 * kR, 1e-15);
  EXPECT_NEAR(far.solver->bounds()[4], kGp * 2 * kR, 1e-15);
  // r_q = 0.02 and a floor 2.5 cm below (detected, but beyond r_q): the r_q bound is the smaller.
  TrustRegionParams q;
  q.query_radius = 0.02;
  auto near = probe({floor_square(), particle(Vec3(0.05, 0.025, 0.0))}, q);
  near.detect();
  EXPECT_NEAR(near.solver->bounds()[4], kGp * (0.02 - kXi), 1e-15);
  // A query radius beyond the detection range cannot be honoured: one clear error naming the key.
  q.query_radius = 0.031;
  try {
    probe({floor_square(), particle(Vec3(0.05, 0.5, 0.0))}, q);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("contact.ogc.query_radius"), std::string::npos) << e.what();
  }
}

TEST(Ogc, ZeroAreaTriangleBoundsByTheDistanceToItsSegment) {
  // A degenerate (collinear) obstacle triangle: the distance is to the segment it collapses to.
  Part sliver{"sliver", ObjectKind::obstacle, {Vec3(-0.1, 0, 0), Vec3(0.1, 0, 0), Vec3(0.0, 0, 0)}};
  sliver.f = {Vec3i(0, 1, 2)};
  auto p = probe({sliver, particle(Vec3(0.03, 0.015, 0.01))});
  p.detect();
  const double d = std::hypot(0.015, 0.01);
  EXPECT_NEAR(p.solver->bounds()[3], kGp * (d - kXi), 1e-15);
}

TEST(Ogc, CoincidentVertexTakesItsBoundFromTheOtherPairs) {
  // A particle on the floor (distance ~1e-17): the shared detection gives a sub-pair closer than
  // 1e-12 no normal and no contact (as for every solver), so the bound comes from the other floor
  // triangle, whose diagonal edge is |0.05 - 0.07| / sqrt 2 away; nothing is NaN.
  test::ExpectWarnings starts_inside_the_offset;
  auto p = probe({floor_square(), particle(Vec3(0.05, 0.0, 0.07))});
  p.detect();
  EXPECT_NEAR(p.solver->bounds()[4], kGp * (0.02 / std::sqrt(2.0) - kXi), 1e-15);
  Positions x = p.scene.state.x;
  x[4] += Vec3(0.0, -0.05, 0.0);
  p.resolve(x);
  EXPECT_TRUE(x[4].allFinite());
}

TEST(Ogc, RigidObjectsAreRejectedByName) {
  const auto box = gen::box(Vec3(0.1, 0.1, 0.1));
  Part rigid{"crate", ObjectKind::rigid, box.v, box.f};
  try {
    probe({floor_square(), rigid});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'crate'"), std::string::npos) << e.what();
  }
}

TEST(Ogc, KeepsTheTrustRegionUntilTooManyVerticesAreTruncated) {
  // After a pass that truncated nothing, the next pass keeps the centres (no detection); after one
  // that truncated more than γ_e of the vertices, it detects again at the new anchors.
  auto p = probe({floor_square(), particle(Vec3(0.05, 0.02, 0.07))});
  p.detect();
  EXPECT_EQ(p.solver->detections(), 1);
  Positions x = p.scene.state.x;
  x[4].x() += 0.001;
  p.resolve(x);
  p.scene.state.x = x;
  p.iteration = 1;
  p.detect();
  EXPECT_EQ(p.solver->detections(), 1);
  EXPECT_EQ(p.solver->centers()[4].x(), 0.05);
  x[4].y() -= 0.05;
  p.resolve(x);
  p.scene.state.x = x;
  p.detect();
  EXPECT_EQ(p.solver->detections(), 2);
  EXPECT_EQ(p.solver->centers()[4], x[4]);
}

TEST(Ogc, RestingContactStallsTheTangentialMotion) {
  // OGC's isotropic bound: a puck resting ξ (1 + 1e-3) above the floor may move γ_p 1e-5 m per
  // detection in any direction, so its slide at 0.5 m/s nearly stops (DAT's planes keep it).
  const double speed = 0.5;
  Simulation sim(test::floor_puck_scene(kXi * (1.0 + 1e-3), speed, "ogc"));
  const Index p = sim.topology().num_vertices() - 1;
  for (int f = 0; f < 10; ++f) {
    const FrameStats fs = sim.step_frame();
    EXPECT_EQ(fs.violations_remaining, 0) << f;
    EXPECT_GE(sim.positions()[p].y(), kXi * (1.0 - 1e-9)) << f;
  }
  EXPECT_LT(sim.positions()[p].x(), 0.1 * speed * 10 / 60.0);
}

TEST(Ogc, ClothOnABoxPassesTheExactAuditEveryFrame) {
  // Dropped from 3 cm onto a 0.2 m box.
  const test::DropResult r = test::drop_cloth_audited(gen::box(Vec3(0.2, 0.2, 0.2)), Vec3(0.01, 0.13, 0.02), "ogc");
  EXPECT_GT(r.detected, 0) << "the cloth was meant to reach the box";
  EXPECT_LT(r.lowest, 0.1 + 0.015);  // reached the top (y = 0.1) within its offset shell
}

TEST(Ogc, AScriptedStepTowardTheVertexComesOutOfItsBound) {
  // The floor is scripted 8 mm up in this pass: the particle 2 cm above keeps γ_p (d − ξ − K).
  auto p = probe({floor_square(), particle(Vec3(0.15, 0.02, -0.1))});
  p.kinematic.assign(5, Vec3::Zero());
  for (Index v = 0; v < 4; ++v) p.kinematic[v] = Vec3(0, 0.008, 0);
  p.detect();
  EXPECT_NEAR(p.solver->bounds()[4], kGp * (0.02 - kXi - 0.008), 1e-15);
}
