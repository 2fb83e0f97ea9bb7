// Plesník's recursion against the closed-form affine projection, and the CCFR projector's own rules
// (sorting, ε retraction, re-check, halting, d < 0).
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include "ccfr/feasibility/plesnik.hpp"
#include "random_regions.hpp"
#include "test_support.hpp"

namespace ccfr {
namespace {

/// x0 - A^T (A A^T)^{-1} (A x0 - b), solved with Eigen's LDLT.
Vec3 closed_form(const Vec3& x0, const std::vector<Vec3>& normals, const std::vector<double>& b) {
  const auto m = static_cast<Eigen::Index>(normals.size());
  Eigen::MatrixXd a(m, 3);
  Eigen::VectorXd bb(m);
  for (Eigen::Index i = 0; i < m; ++i) {
    a.row(i) = normals[static_cast<size_t>(i)].transpose();
    bb(i) = b[static_cast<size_t>(i)];
  }
  const Eigen::MatrixXd g = a * a.transpose();
  return x0 - a.transpose() * g.ldlt().solve(a * x0 - bb);
}

TEST(PlesnikRecursion, MatchesClosedFormForOneToThreeIndependentPlanes) {
  auto g = test::rng(1234);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst = 0.0;
  for (int trial = 0; trial < 3000; ++trial) {
    const int m = 1 + trial % 3;
    std::vector<Vec3> normals;
    std::vector<double> b;
    for (int i = 0; i < m; ++i) {
      normals.push_back(test::random_unit(g));
      b.push_back(u(g));
    }
    // Keep the system well conditioned so the comparison measures the recursion, not the data.
    Eigen::Matrix3d a = Eigen::Matrix3d::Identity();
    for (int i = 0; i < m; ++i) a.row(i) = normals[static_cast<size_t>(i)].transpose();
    if (m == 2 && normals[0].cross(normals[1]).norm() < 0.2) continue;
    if (m == 3 && std::abs(a.determinant()) < 0.1) continue;
    const Vec3 x0(u(g), u(g), u(g));

    PlesnikRecursion rec;
    rec.reset(x0);
    for (int i = 0; i < m; ++i)
      ASSERT_EQ(rec.add(normals[static_cast<size_t>(i)], b[static_cast<size_t>(i)], 1e-12),
                PlesnikRecursion::Step::added);
    const Vec3 ref = closed_form(x0, normals, b);
    worst = std::max(worst, (rec.x - ref).norm());
    ASSERT_LT((rec.x - ref).norm(), 1e-10) << "trial " << trial << " m=" << m;
    // Every intermediate system too: the projection onto the first k planes.
    for (int i = 0; i < m; ++i)
      EXPECT_NEAR(normals[static_cast<size_t>(i)].dot(rec.x), b[static_cast<size_t>(i)], 1e-10);
  }
  std::printf("[plesnik affine] worst |x - closed form| = %.3e\n", worst);
}

TEST(PlesnikRecursion, DenominatorThatVanishesForAnIndependentPlaneIsHandledBySignFlip) {
  // After e_x and e_y the ERO direction is c(1,1,0); a_2 = (0.5, 0.5, sqrt(0.5)) has a_2.v = a_0.v,
  // so line 14's denominator is zero although the three normals are independent.
  const std::vector<Vec3> normals = {Vec3::UnitX(), Vec3::UnitY(), Vec3(0.5, 0.5, std::sqrt(0.5))};
  const std::vector<double> b = {0.3, -0.2, 0.7};
  const Vec3 x0(1.0, 2.0, -1.0);
  PlesnikRecursion rec;
  rec.reset(x0);
  for (int i = 0; i < 3; ++i)
    EXPECT_EQ(rec.add(normals[static_cast<size_t>(i)], b[static_cast<size_t>(i)], 1e-12),
              PlesnikRecursion::Step::added);
  EXPECT_LT((rec.x - closed_form(x0, normals, b)).norm(), 1e-12);
}

TEST(PlesnikRecursion, DependentEquationsAreSkipped) {
  PlesnikRecursion rec;
  rec.reset(Vec3(1, 1, 1));
  EXPECT_EQ(rec.add(Vec3::UnitZ(), 0.5, 1e-12), PlesnikRecursion::Step::added);
  EXPECT_EQ(rec.add(Vec3::UnitX(), 0.0, 1e-12), PlesnikRecursion::Step::added);
  // In the span of the two: (x + z)/sqrt2 = c, consistent with x = 0, z = 0.5 for c = 0.5/sqrt2.
  EXPECT_EQ(rec.add(Vec3(1, 0, 1).normalized(), 0.5 / std::sqrt(2.0), 1e-12), PlesnikRecursion::Step::redundant);
  EXPECT_LT((rec.x - Vec3(0, 1, 0.5)).norm(), 1e-14);
  EXPECT_EQ(rec.add(Vec3::UnitY(), 0.25, 1e-12), PlesnikRecursion::Step::added);
  EXPECT_EQ(rec.add(Vec3(1, 1, 1).normalized(), 0.0, 1e-12), PlesnikRecursion::Step::redundant);  // 4th in R^3
  EXPECT_LT((rec.x - Vec3(0, 0.25, 0.5)).norm(), 1e-14);
  EXPECT_EQ(rec.add(Vec3::Zero(), 1.0, 1e-12), PlesnikRecursion::Step::redundant);
}

/// The projector's passes written out with one full sort of every plane by violation depth (the
/// paper's order), ending like the projector (re-check, exact replacement, halting).
ProjectResult full_sort_reference(const ProjectorParams& params, const Vec3& anchor, const Vec3& candidate,
                                  const std::vector<HalfSpace>& planes) {
  const double tol = params.feasibility_tolerance;
  const Vec3 q = candidate - anchor;
  std::vector<std::pair<double, std::uint32_t>> order;
  for (std::uint32_t k = 0; k < planes.size(); ++k) order.emplace_back(planes[k].n.dot(q) + planes[k].d, k);
  std::sort(order.begin(), order.end());
  ProjectResult res;
  PlesnikRecursion rec;
  Vec3 x_pass = q;
  for (int it = 1; it <= params.max_iterations; ++it) {
    rec.reset(x_pass);
    Vec3 x_check = x_pass;
    for (const auto& [rho, k] : order) {
      const HalfSpace& h = planes[k];
      if (h.n.dot(x_check) + h.d >= -tol) continue;
      if (rec.add(h.n, -h.d, params.redundancy_tolerance) == PlesnikRecursion::Step::added)
        x_check = retract_toward_anchor(rec.x, params.epsilon);
    }
    x_pass = x_check;
    res.iterations = it;
    bool ok = true;
    for (const auto& h : planes) ok = ok && h.n.dot(x_pass) + h.d >= -tol;
    if (ok) {
      res.x = anchor + x_pass;
      res.status = (x_pass - q).squaredNorm() > q.squaredNorm() ? ProjectStatus::infeasible : ProjectStatus::projected;
      return res;  // infeasible marks "the projector replaces this point": compared separately
    }
  }
  res.status = ProjectStatus::halted;
  return res;
}

// The projector sorts only the planes violated at the candidate, and of the rest only those
// violated at the point of the pass, collected again after each addition: every point it returns
// equals the full sort's bit for bit, on dense regions (up to 300 planes, clustered normals, as a
// vertex of folded cloth has). So does its skipping of planes whose value at the candidate is
// too far above zero for the pass's move to reach.
TEST(PlesnikProjector, LazySortVisitsPlanesExactlyAsTheFullSort) {
  auto g = test::rng(2024);
  ProjectorParams params;
  params.exact_fallback = false;  // compare Plesnik's own passes
  const PlesnikProjector proj(params);
  int compared = 0, multi_pass = 0, rest_needed = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const int count = 1 + trial % 300;
    test::RandomProblem p = test::random_problem(g, count);
    if (trial % 2 == 1) {
      // A wedge in a random frame: the candidate violates plane 1 only, and its projection onto
      // plane 1 violates plane 2, which the candidate satisfied; the random planes stay behind.
      const Vec3 ez = test::random_unit(g), ex = ez.unitOrthogonal(), ey = ez.cross(ex);
      std::uniform_real_distribution<double> u(0.5, 1.0);
      const double a = 0.003 * u(g), depth = 0.005 * u(g), d1 = 0.002 * u(g);
      p.candidate = p.anchor + a * ex - depth * ez;
      for (auto& h : p.planes) h.d += 0.02;
      p.planes.insert(p.planes.begin() + count / 2, HalfSpace{ez, d1});
      p.planes.push_back(HalfSpace{(-ex - ez).normalized(), 0.0003 * u(g)});
    }
    if (trial % 7 == 3) {
      // Normals of lengths 0.5-2 (the same half-spaces, other values): the projector's bound that
      // skips evaluating planes far from violation must scale with |n|.
      std::uniform_real_distribution<double> scale(0.5, 2.0);
      for (auto& h : p.planes) {
        const double f = scale(g);
        h.n *= f;
        h.d *= f;
      }
    }
    const ProjectResult ref = full_sort_reference(params, p.anchor, p.candidate, p.planes);
    const ProjectResult got = proj.project(p.anchor, p.candidate, p.planes);
    if (got.active == 0) continue;
    if (ref.status == ProjectStatus::infeasible) continue;  // replaced by the exact projection
    ++compared;
    multi_pass += ref.iterations > 1;
    ASSERT_EQ(got.status, ref.status) << "trial " << trial;
    ASSERT_EQ(got.iterations, ref.iterations) << "trial " << trial;
    if (ref.status == ProjectStatus::projected) {
      ASSERT_EQ(got.x, ref.x) << "trial " << trial << ", " << count << " planes";
      // Whether a plane that was satisfied at the candidate had to be visited.
      int satisfied_then_violated = 0;
      const Vec3 q = p.candidate - p.anchor, x = ref.x - p.anchor;
      for (const auto& h : p.planes)
        satisfied_then_violated += h.n.dot(q) + h.d >= -params.feasibility_tolerance && h.n.dot(x) + h.d < 1e-5;
      rest_needed += satisfied_then_violated > 0;
    }
  }
  EXPECT_GT(compared, 1000);
  EXPECT_GT(multi_pass, 10);
  EXPECT_GT(rest_needed, 10);
}

// The scans read a shortlist of the planes that could be violated within twice the first scan's
// move, and rebuild it when a later move goes farther. Thin slabs (pairs of nearly opposite
// planes around the anchor) make the second addition move the point many times farther than the
// first, onto planes far from violation at the candidate: the points must still equal the full
// scan's, and such far moves must occur (a shortlist never rebuilt fails here).
TEST(PlesnikProjector, ShortlistFindsThePlanesOfMovesBeyondItsLimit) {
  auto g = test::rng(77);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  ProjectorParams params;
  params.exact_fallback = false;
  const PlesnikProjector proj(params);
  int compared = 0, far_moves = 0;
  for (int trial = 0; trial < 6000; ++trial) {
    const int count = 4 + trial % 120;
    test::RandomProblem p = test::random_problem(g, count);
    // A slab of width w around the anchor, tilted by phi, that the candidate leaves by a small depth.
    const Vec3 a = test::random_unit(g), t = a.unitOrthogonal();
    const double w = 0.002 * (0.2 + u(g)), phi = 0.02 + 0.3 * u(g);
    p.planes.insert(p.planes.begin() + count / 3, HalfSpace{a, 0.5 * w});
    p.planes.push_back(HalfSpace{(-a + phi * t).normalized(), 0.5 * w});
    p.candidate = p.anchor - (0.5 * w + 0.0005 * u(g)) * a + 0.01 * (u(g) - 0.5) * t;
    const ProjectResult ref = full_sort_reference(params, p.anchor, p.candidate, p.planes);
    const ProjectResult got = proj.project(p.anchor, p.candidate, p.planes);
    if (got.active == 0 || ref.status == ProjectStatus::infeasible) continue;
    ++compared;
    ASSERT_EQ(got.status, ref.status) << "trial " << trial;
    ASSERT_EQ(got.iterations, ref.iterations) << "trial " << trial;
    if (ref.status != ProjectStatus::projected) continue;
    ASSERT_EQ(got.x, ref.x) << "trial " << trial;
    // A move more than twice the candidate's deepest violation: beyond a first shortlist.
    double deepest = 0.0;
    const Vec3 q = p.candidate - p.anchor;
    for (const auto& h : p.planes) deepest = std::max(deepest, -(h.n.dot(q) + h.d));
    far_moves += (ref.x - p.candidate).norm() > 3.0 * deepest;
  }
  EXPECT_GT(compared, 1000);
  EXPECT_GT(far_moves, 20);
}

TEST(PlesnikProjector, SinglePlaneIsProjectionRetractedByEpsilonTowardTheAnchor) {
  const PlesnikProjector proj;
  const Vec3 anchor(0.1, 0.2, 0.3);
  const HalfSpace floor{Vec3::UnitZ(), 0.01};  // z' >= z - 0.01
  const Vec3 cand = anchor + Vec3(0.05, 0.0, -0.03);
  const auto r = proj.project(anchor, cand, std::span(&floor, 1));
  ASSERT_EQ(r.status, ProjectStatus::projected);
  EXPECT_EQ(r.active, 1);
  EXPECT_EQ(r.iterations, 1);
  const Vec3 on_plane(0.05, 0.0, -0.01);  // relative to the anchor
  const Vec3 expected = anchor + on_plane * ((on_plane.norm() - 1e-6) / on_plane.norm());
  EXPECT_LT((r.x - expected).norm(), 1e-15);
  EXPECT_GT(floor.value(anchor, r.x), 0.0);
}

TEST(PlesnikProjector, EpsilonIsConfigurableAndZeroGivesTheExactProjection) {
  ProjectorParams p;
  p.epsilon = 0.0;
  const PlesnikProjector proj(p);
  const HalfSpace floor{Vec3::UnitZ(), 0.0};
  const auto r = proj.project(Vec3::Zero(), Vec3(0.3, -0.2, -0.5), std::span(&floor, 1));
  ASSERT_EQ(r.status, ProjectStatus::projected);
  EXPECT_LT((r.x - Vec3(0.3, -0.2, 0.0)).norm(), 1e-16);
}

TEST(PlesnikProjector, CandidateInsideIsReturnedUnchanged) {
  const PlesnikProjector proj;
  const std::vector<HalfSpace> planes = {{Vec3::UnitZ(), 0.01}, {Vec3::UnitX(), 0.02}};
  const Vec3 cand(0.003, -0.004, 0.005);
  const auto r = proj.project(Vec3::Zero(), cand, planes);
  EXPECT_EQ(r.status, ProjectStatus::feasible);
  EXPECT_EQ(r.x, cand);
  EXPECT_EQ(r.active, 0);
  EXPECT_EQ(r.iterations, 0);
}

TEST(PlesnikProjector, WedgeNeedsTheSecondEquationAndLandsOnTheEdge) {
  // Two planes through the anchor at a right angle: the projection of (-1, -1, 0.5) is (0, 0, 0.5).
  ProjectorParams p;
  p.epsilon = 0.0;
  const PlesnikProjector proj(p);
  const std::vector<HalfSpace> planes = {{Vec3::UnitX(), 0.0}, {Vec3::UnitY(), 0.0}};
  const auto r = proj.project(Vec3::Zero(), Vec3(-1.0, -2.0, 0.5), planes);
  ASSERT_EQ(r.status, ProjectStatus::projected);
  EXPECT_LT((r.x - Vec3(0.0, 0.0, 0.5)).norm(), 1e-14);
  EXPECT_EQ(r.active, 2);
}

TEST(PlesnikProjector, DeepestPlaneFirstMakesStackedCardsOneProjection) {
  // Parallel planes (stacked cards): projecting onto the deepest satisfies the others. In the
  // stored order the shallow one comes first; the sort must put the deep one first.
  ProjectorParams p;
  p.epsilon = 0.0;
  p.max_iterations = 1;
  const PlesnikProjector proj(p);
  const std::vector<HalfSpace> planes = {{Vec3::UnitZ(), 0.05}, {Vec3::UnitZ(), 0.01}, {Vec3::UnitZ(), 0.03}};
  const auto r = proj.project(Vec3::Zero(), Vec3(0.2, 0.0, -0.1), planes);
  ASSERT_EQ(r.status, ProjectStatus::projected);
  EXPECT_EQ(r.active, 3);
  EXPECT_LT((r.x - Vec3(0.2, 0.0, -0.01)).norm(), 1e-15);
}

TEST(PlesnikProjector, BudgetExhaustedFallsBackToTheAnchorAsHalted) {
  // One pass fixes the planes violated at its start, in depth order, as equalities; planes it
  // breaks along the way are left for the next pass. Seeded random sets contain such cases: with a
  // budget of one pass they must halt at the anchor, and a larger budget must recover some.
  auto g = test::rng(99);
  ProjectorParams one;
  one.max_iterations = 1;
  one.exact_fallback = false;  // the paper's plain halting
  const PlesnikProjector short_budget(one);
  ProjectorParams many;
  many.max_iterations = 50;
  many.exact_fallback = false;
  const PlesnikProjector long_budget(many);
  int halted = 0, recovered = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const auto prob = test::random_problem(g, 8);
    const auto r1 = short_budget.project(prob.anchor, prob.candidate, prob.planes);
    if (r1.status != ProjectStatus::halted) continue;
    ++halted;
    EXPECT_EQ(r1.x, prob.anchor);  // the fallback is the anchor, bit for bit
    EXPECT_EQ(r1.iterations, 1);
    EXPECT_GE(min_value(prob.anchor, r1.x, prob.planes), 0.0);
    const auto r50 = long_budget.project(prob.anchor, prob.candidate, prob.planes);
    if (r50.status == ProjectStatus::projected) ++recovered;
  }
  EXPECT_GT(halted, 0) << "the seeded set should contain single-pass halting cases";
  EXPECT_GT(recovered, 0) << "more passes should recover some of them";
}

TEST(PlesnikProjector, UnconvergedPassesTakeTheExactProjectionInsteadOfHalting) {
  // The anchor is feasible, so a region is never empty: where the passes halt, the exact
  // projection (exact_fallback, the default) must be taken instead, and it must be the true
  // Euclidean projection: compared with the brute-force reference of random_regions.hpp.
  auto g = test::rng(99);
  ProjectorParams halt;
  halt.max_iterations = 1;
  halt.exact_fallback = false;
  halt.epsilon = 0.0;  // no retraction, so the answer is comparable with the reference
  ProjectorParams rescue = halt;
  rescue.exact_fallback = true;
  ProjectorParams rescue_eps = rescue;
  rescue_eps.epsilon = 1e-6;
  int rescued = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const auto prob = test::random_problem(g, 8);
    if (PlesnikProjector(halt).project(prob.anchor, prob.candidate, prob.planes).status != ProjectStatus::halted)
      continue;
    const auto r = PlesnikProjector(rescue).project(prob.anchor, prob.candidate, prob.planes);
    ASSERT_EQ(r.status, ProjectStatus::projected) << "trial " << trial;
    EXPECT_TRUE(r.rescued);
    Vec3 ref;
    ASSERT_TRUE(test::reference_projection(prob.candidate - prob.anchor, prob.planes, 1e-12, ref));
    EXPECT_LT((r.x - (prob.anchor + ref)).norm(), 1e-10) << "trial " << trial;
    // With the ε retraction the point is strictly inside and not farther from the candidate
    // than the anchor is (a halt's answer).
    const auto re = PlesnikProjector(rescue_eps).project(prob.anchor, prob.candidate, prob.planes);
    ASSERT_EQ(re.status, ProjectStatus::projected);
    EXPECT_GE(min_value(prob.anchor, re.x, prob.planes), 0.0) << "trial " << trial;
    EXPECT_LE((re.x - prob.candidate).norm(), (prob.anchor - prob.candidate).norm()) << "trial " << trial;
    ++rescued;
  }
  EXPECT_GT(rescued, 10) << "the seeded set should contain single-pass halting cases";
}

TEST(PlesnikProjector, NegativeDIsProjectedExactlyNotFallenBackToTheInfeasibleAnchor) {
  // The anchor is 0.01 inside the offset of the floor: d = -0.01. The closest admissible point of a
  // candidate that stays put is 0.01 (+ ε margin) up.
  const PlesnikProjector proj;
  const HalfSpace floor{Vec3::UnitZ(), -0.01};
  const Vec3 anchor(0, 0, 0);
  const auto r = proj.project(anchor, Vec3(0.02, 0.0, 0.0), std::span(&floor, 1));
  ASSERT_EQ(r.status, ProjectStatus::projected);
  EXPECT_NEAR(r.x.z(), 0.01 + 1e-6, 1e-15);
  EXPECT_NEAR(r.x.x(), 0.02, 1e-15);
  EXPECT_GE(floor.value(anchor, r.x), 0.0);
}

TEST(PlesnikProjector, NegativeDWithEmptyRegionIsInfeasibleAndKeepsTheAnchor) {
  // Squeezed: z' >= 0.01 and z' <= 0 at once.
  const PlesnikProjector proj;
  const std::vector<HalfSpace> planes = {{Vec3::UnitZ(), -0.01}, {-Vec3::UnitZ(), 0.0}};
  const Vec3 anchor(1, 2, 3);
  const auto r = proj.project(anchor, anchor + Vec3(0, 0, -0.5), planes);
  EXPECT_EQ(r.status, ProjectStatus::infeasible);
  EXPECT_EQ(r.x, anchor);
}

}  // namespace
}  // namespace ccfr
