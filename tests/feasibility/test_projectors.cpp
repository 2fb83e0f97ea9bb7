// Every projector on seeded random polyhedral regions and on degenerate regions, checked against
// an independent brute-force projection (random_regions.hpp); the factory; project_all.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/feasibility/exact_projector.hpp"
#include "ccfr/feasibility/plesnik.hpp"
#include "ccfr/feasibility/projector.hpp"
#include "ccfr/feasibility/successive_projection.hpp"
#include "random_regions.hpp"
#include "test_support.hpp"

namespace ccfr {
namespace {

constexpr double kTol = 1e-9;

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(std::min<double>(v.size() - 1, std::floor(q * static_cast<double>(v.size()))))];
}

class EveryProjector : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryProjector, RandomRegionsEndFeasibleOrSayTheyDoNot) {
  const auto proj = make_projector(GetParam());
  EXPECT_EQ(proj->name(), GetParam());
  auto g = test::rng(2024);
  int counts[4] = {0, 0, 0, 0};
  for (int trial = 0; trial < 6000; ++trial) {
    const auto prob = test::random_problem(g, 1 + trial % 16);
    const auto r = proj->project(prob.anchor, prob.candidate, prob.planes);
    ++counts[static_cast<int>(r.status)];
    const double lo = min_value(prob.anchor, r.x, prob.planes);
    const int active = static_cast<int>(std::count_if(prob.planes.begin(), prob.planes.end(), [&](const HalfSpace& h) {
      return h.value(prob.anchor, prob.candidate) < -1e-12;
    }));
    EXPECT_EQ(r.active, active);
    switch (r.status) {
      case ProjectStatus::feasible:
        EXPECT_EQ(active, 0);
        EXPECT_EQ(r.x, prob.candidate);
        break;
      case ProjectStatus::projected:
        EXPECT_GE(lo, -kTol) << "trial " << trial;
        break;
      case ProjectStatus::halted:
        EXPECT_EQ(r.x, prob.anchor);
        EXPECT_GE(lo, 0.0);
        break;
      case ProjectStatus::infeasible:
        // Only successive projection gives up on non-empty regions, and it must be honest.
        EXPECT_EQ(GetParam(), "successive_projection");
        EXPECT_LT(lo, -1e-12);
        break;
    }
  }
  std::printf("[%s] feasible %d projected %d halted %d infeasible %d\n", GetParam().c_str(), counts[0], counts[1],
              counts[2], counts[3]);
  EXPECT_GT(counts[1], 1000);  // the generator produces plenty of violations
}

INSTANTIATE_TEST_SUITE_P(Feasibility, EveryProjector, ::testing::ValuesIn(projector_names()),
                         [](const auto& info) { return info.param; });

TEST(ExactProjector, AgreesWithBruteForceReferenceOnRandomRegions) {
  ProjectorParams p;
  p.epsilon = 0.0;
  const ExactProjector exact(p);
  auto g = test::rng(77);
  double worst = 0.0;
  int compared = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const auto prob = test::random_problem(g, 1 + trial % 16);
    Vec3 ref;
    ASSERT_TRUE(test::reference_projection(prob.candidate - prob.anchor, prob.planes, 1e-12, ref));
    const auto r = exact.project(prob.anchor, prob.candidate, prob.planes);
    ASSERT_NE(r.status, ProjectStatus::infeasible);
    const double err = (r.x - (prob.anchor + ref)).norm();
    worst = std::max(worst, err);
    EXPECT_LT(err, 1e-10) << "trial " << trial;
    ++compared;
  }
  std::printf("[exact vs reference] %d problems, worst distance %.3e\n", compared, worst);
}

TEST(PlesnikProjector, GapToExactProjectionIsReported) {
  // Plesník adds violated planes as equalities and never drops one, so it may land on a feasible
  // point that is not the closest. Print, not assert, how far it lands from the optimum.
  const PlesnikProjector plesnik;
  const ExactProjector exact;
  auto g = test::rng(31337);
  std::vector<double> gaps, rel;
  int halted = 0, violated = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const auto prob = test::random_problem(g, 1 + trial % 16);
    const auto rp = plesnik.project(prob.anchor, prob.candidate, prob.planes);
    if (rp.status == ProjectStatus::feasible) continue;
    ++violated;
    if (rp.status == ProjectStatus::halted) {
      ++halted;
      continue;
    }
    const auto re = exact.project(prob.anchor, prob.candidate, prob.planes);
    ASSERT_EQ(re.status, ProjectStatus::projected);
    const double gap = (rp.x - re.x).norm();
    gaps.push_back(gap);
    rel.push_back(gap / std::max(1e-300, (re.x - prob.candidate).norm()));
    // The exact projection is never farther from the candidate than Plesník's point (both retract by ε).
    EXPECT_LE((re.x - prob.candidate).norm(), (rp.x - prob.candidate).norm() + 2e-6);
  }
  std::printf(
      "[plesnik gap] violated %d halted %d (%.2f%%); |x_plesnik - x_exact| p50 %.2e p90 %.2e p99 %.2e max %.2e;"
      " relative to the exact displacement p50 %.2e p90 %.2e p99 %.2e max %.2e\n",
      violated, halted, 100.0 * halted / std::max(violated, 1), percentile(gaps, 0.5), percentile(gaps, 0.9),
      percentile(gaps, 0.99), percentile(gaps, 1.0), percentile(rel, 0.5), percentile(rel, 0.9), percentile(rel, 0.99),
      percentile(rel, 1.0));
}

// ---- degenerate regions: each checked for all three projectors against a hand-derived answer ----

struct Case {
  const char* what;
  Vec3 anchor, candidate;
  std::vector<HalfSpace> planes;
  Vec3 expected;  // the exact projection (ε = 0)
};

std::vector<Case> degenerate_cases() {
  const Vec3 z = Vec3::UnitZ(), x = Vec3::UnitX();
  const Vec3 tilt = Vec3(1e-9, 0.0, 1.0).normalized();
  std::vector<Case> c;
  c.push_back(
      {"duplicated planes", Vec3(1, 1, 1), Vec3(1.2, 1, 0.9), {{z, 0.05}, {z, 0.05}, {z, 0.05}}, Vec3(1.2, 1, 0.95)});
  c.push_back(
      {"duplicated wedge", Vec3::Zero(), Vec3(-0.1, 0.3, -0.2), {{z, 0}, {x, 0}, {z, 0}, {x, 0}}, Vec3(0, 0.3, 0)});
  c.push_back({"nearly parallel stacked cards",
               Vec3::Zero(),
               Vec3(0.01, 0.02, -0.1),
               {{z, 0.03}, {tilt, 0.02}, {z, 0.01}, {tilt, 0.025}},
               Vec3(0.01, 0.02, -0.01)});
  c.push_back(
      {"opposing planes, thin slab", Vec3::Zero(), Vec3(0.0, 0.1, 0.3), {{z, 1e-4}, {-z, 1e-4}}, Vec3(0.0, 0.1, 1e-4)});
  c.push_back({"zero-width slab", Vec3::Zero(), Vec3(0.2, 0.1, -0.3), {{z, 0.0}, {-z, 0.0}}, Vec3(0.2, 0.1, 0.0)});
  c.push_back({"zero-width slab and a wall",
               Vec3::Zero(),
               Vec3(-0.2, 0.1, -0.3),
               {{z, 0.0}, {-z, 0.0}, {x, 0.0}},
               Vec3(0.0, 0.1, 0.0)});
  c.push_back({"corner of three planes",
               Vec3::Zero(),
               Vec3(-0.1, -0.2, -0.3),
               {{x, 0.0}, {Vec3::UnitY(), 0.0}, {z, 0.0}},
               Vec3(0, 0, 0)});
  return c;
}

TEST(Degenerate, EveryProjectorReachesTheHandDerivedAnswerWithinItsGuarantees) {
  ProjectorParams p;
  p.epsilon = 0.0;
  for (const auto& name : projector_names()) {
    const auto proj = make_projector(name, p);
    for (const auto& c : degenerate_cases()) {
      const auto r = proj->project(c.anchor, c.candidate, c.planes);
      SCOPED_TRACE(name + ": " + c.what);
      ASSERT_EQ(r.status, ProjectStatus::projected);
      EXPECT_GE(min_value(c.anchor, r.x, c.planes), -1e-12);
      if (name == "exact") EXPECT_LT((r.x - c.expected).norm(), 1e-12);
      // Plesník and successive projection are exact here as well: these regions have one optimal
      // active set that the deepest-first order (or one sweep) finds.
      if (name == "plesnik") EXPECT_LT((r.x - c.expected).norm(), 1e-9);
    }
  }
}

TEST(Degenerate, NoPlanesMeansFeasible) {
  for (const auto& name : projector_names()) {
    const auto r = make_projector(name)->project(Vec3(1, 2, 3), Vec3(4, 5, 6), {});
    EXPECT_EQ(r.status, ProjectStatus::feasible) << name;
    EXPECT_EQ(r.x, Vec3(4, 5, 6)) << name;
  }
}

// falls_below stops at the first plane below the level; its answer must be min_value's on every
// input: planes exactly at the level, NaN or infinite planes, NaN positions and levels, no planes.
TEST(Degenerate, FallsBelowAnswersAsTheFullMinimum) {
  auto g = test::rng(31);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> pick(0, 9);
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  int below = 0, above = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const Vec3 anchor(u(g), u(g), u(g));
    Vec3 x = anchor + 0.01 * Vec3(u(g), u(g), u(g));
    if (trial % 97 == 0) x[trial % 3] = nan;
    std::vector<HalfSpace> planes(static_cast<size_t>(trial % 40));
    for (auto& h : planes) {
      h.n = test::random_unit(g);
      h.d = 0.01 * u(g);
      if (pick(g) == 0) h.d = -h.n.dot(x - anchor);  // exactly zero at x, up to rounding
      if (trial % 53 == 0 && pick(g) == 0) h.d = pick(g) < 5 ? nan : inf;
    }
    double level = trial % 3 == 0 ? 0.0 : 0.005 * u(g);
    if (trial % 211 == 0) level = nan;
    if (trial % 223 == 0) level = inf;
    // Reference: the minimum over all planes, NaN as soon as one value is NaN.
    double lo = inf;
    for (const auto& h : planes) {
      const double r = (x - anchor).dot(h.n) + h.d;
      lo = std::isnan(r) || std::isnan(lo) ? nan : std::min(lo, r);
    }
    const bool expected = !(lo >= level);
    ASSERT_EQ(falls_below(anchor, x, planes, level), expected) << "trial " << trial;
    ASSERT_EQ(expected, !(min_value(anchor, x, planes) >= level)) << "trial " << trial;
    (expected ? below : above)++;
  }
  EXPECT_GT(below, 2000);
  EXPECT_GT(above, 500);
}

TEST(Degenerate, NanCandidateIsInfeasibleAndKeepsTheAnchor) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<HalfSpace> planes = {{Vec3::UnitZ(), 0.01}};
  for (const auto& name : projector_names()) {
    const auto proj = make_projector(name);
    for (const auto& planes_used : {planes, std::vector<HalfSpace>{}}) {
      const auto r = proj->project(Vec3(1, 2, 3), Vec3(nan, 0.0, 0.0), planes_used);
      EXPECT_EQ(r.status, ProjectStatus::infeasible) << name;
      EXPECT_EQ(r.x, Vec3(1, 2, 3)) << name;
    }
  }
}

TEST(Degenerate, NegativeDOnlyTheExactProjectionAnswers) {
  // Anchor inside the offset of two walls (d < 0): Plesník delegates to the exact projection;
  // successive projection just projects. Both end feasible; the exact answer keeps an ε margin.
  const std::vector<HalfSpace> planes = {{Vec3::UnitZ(), -0.01}, {Vec3::UnitX(), -0.02}};
  const Vec3 anchor(0.5, 0.5, 0.5);
  const Vec3 cand = anchor + Vec3(0.0, 0.1, 0.0);
  const auto exact = make_projector("exact")->project(anchor, cand, planes);
  ASSERT_EQ(exact.status, ProjectStatus::projected);
  EXPECT_LT((exact.x - (anchor + Vec3(0.02 + 1e-6, 0.1, 0.01 + 1e-6))).norm(), 1e-14);
  const auto pl = make_projector("plesnik")->project(anchor, cand, planes);
  EXPECT_EQ(pl.status, ProjectStatus::projected);
  EXPECT_EQ(pl.x, exact.x);
  EXPECT_EQ(pl.active, 2);
  const auto sp = make_projector("successive_projection")->project(anchor, cand, planes);
  EXPECT_EQ(sp.status, ProjectStatus::projected);
  EXPECT_GE(min_value(anchor, sp.x, planes), -1e-12);
}

TEST(Degenerate, NegativeDThinnerThanEpsilonStillProjects) {
  // A zero-width slab away from the anchor: the ε-shrunk region is empty, the region itself is not.
  const std::vector<HalfSpace> planes = {{Vec3::UnitZ(), -0.01}, {-Vec3::UnitZ(), 0.01}};
  const auto r = make_projector("exact")->project(Vec3::Zero(), Vec3(0.3, 0.0, 0.0), planes);
  ASSERT_EQ(r.status, ProjectStatus::projected);
  EXPECT_LT((r.x - Vec3(0.3, 0.0, 0.01)).norm(), 1e-15);
}

TEST(Degenerate, EmptyRegionIsInfeasible) {
  const std::vector<HalfSpace> planes = {
      {Vec3::UnitX(), 0.0}, {Vec3::UnitY(), 0.0}, {Vec3(-1, -1, 0).normalized(), -0.01}};
  for (const auto& name : {"plesnik", "exact"}) {
    const auto r = make_projector(name)->project(Vec3::Zero(), Vec3(0.1, -0.1, 0.0), planes);
    EXPECT_EQ(r.status, ProjectStatus::infeasible) << name;
    EXPECT_EQ(r.x, Vec3::Zero()) << name;
  }
  const auto sp = make_projector("successive_projection")->project(Vec3::Zero(), Vec3(0.1, -0.1, 0.0), planes);
  EXPECT_EQ(sp.status, ProjectStatus::infeasible);
  EXPECT_LT(min_value(Vec3::Zero(), sp.x, planes), -1e-12);
}

TEST(SuccessiveProjection, NarrowWedgeNeedsManySweeps) {
  // A wedge of opening 2 degrees around +z, apex line along y. From below the apex, alternating
  // projections zig-zag toward it and shrink the error by about cos(2 degrees) per projection.
  const double a = M_PI / 180.0;
  const std::vector<HalfSpace> planes = {{Vec3(-std::cos(a), 0, std::sin(a)), 0.0},
                                         {Vec3(std::cos(a), 0, std::sin(a)), 0.0}};
  const Vec3 cand(0.3, 0.2, -1.0);
  ProjectorParams few;
  few.sweeps = 3;
  const auto r3 = SuccessiveProjectionProjector(few).project(Vec3::Zero(), cand, planes);
  EXPECT_EQ(r3.status, ProjectStatus::infeasible);
  EXPECT_EQ(r3.iterations, 3);
  ProjectorParams many;
  many.sweeps = 100000;  // ~45k projections bring the violation below 1e-12
  const auto rm = SuccessiveProjectionProjector(many).project(Vec3::Zero(), cand, planes);
  EXPECT_EQ(rm.status, ProjectStatus::projected);
  EXPECT_GT(rm.iterations, 3);
  // Plesník lands on the apex line (x = 0, z = 0) in one pass.
  const auto pl = make_projector("plesnik")->project(Vec3::Zero(), cand, planes);
  ASSERT_EQ(pl.status, ProjectStatus::projected);
  EXPECT_LT(std::abs(pl.x.x()) + std::abs(pl.x.z()), 1e-9);
  EXPECT_EQ(pl.iterations, 1);
}

// ---- factory ----

TEST(Factory, ListsThreeProjectorsAndRejectsUnknownNamesListingTheValidOnes) {
  EXPECT_EQ(projector_names(), (std::vector<std::string>{"plesnik", "successive_projection", "exact"}));
  try {
    make_projector("plesnick");
    FAIL() << "expected ccfr::Error";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("plesnick"), std::string::npos);
    for (const auto& n : projector_names()) EXPECT_NE(msg.find(n), std::string::npos) << msg;
  }
}

TEST(Factory, RejectsInvalidParameters) {
  ProjectorParams p;
  p.max_iterations = 0;
  EXPECT_THROW(make_projector("plesnik", p), Error);
  p = {};
  p.epsilon = -1.0;
  EXPECT_THROW(make_projector("exact", p), Error);
  p = {};
  p.sweeps = 0;
  EXPECT_THROW(make_projector("successive_projection", p), Error);
  EXPECT_NO_THROW(make_projector("plesnik", ProjectorParams{}));
}

// ---- project_all ----

TEST(ProjectAll, MatchesPerVertexCallsSkipsKinematicVerticesAndIsDeterministic) {
  auto g = test::rng(5);
  const Index n = 3000;
  std::vector<std::vector<TaggedHalfSpace>> buffers(1);
  Positions anchor(n), cand(n);
  std::vector<double> inv_mass(n, 1.0);
  std::vector<test::RandomProblem> probs;
  for (Index v = 0; v < n; ++v) {
    probs.push_back(test::random_problem(g, static_cast<int>(v % 9)));  // includes empty regions
    anchor[static_cast<size_t>(v)] = probs.back().anchor;
    cand[static_cast<size_t>(v)] = probs.back().candidate;
    for (size_t k = 0; k < probs.back().planes.size(); ++k)
      buffers[0].push_back({v, static_cast<std::uint64_t>(k), probs.back().planes[k]});
    if (v % 7 == 3) inv_mass[static_cast<size_t>(v)] = 0.0;
  }
  RegionSet regions;
  build_region_set(n, buffers, regions);

  for (const auto& name : projector_names()) {
    const auto proj = make_projector(name);
    Positions x = cand;
    const BatchStats s = project_all(*proj, regions, anchor, x, inv_mass);
    BatchStats expect;
    for (Index v = 0; v < n; ++v) {
      const auto i = static_cast<size_t>(v);
      if (inv_mass[i] == 0.0) {
        EXPECT_EQ(x[i], cand[i]) << "kinematic vertex moved";
        continue;
      }
      const auto r = proj->project(anchor[i], cand[i], regions.of(v));
      EXPECT_EQ(x[i], r.x) << name << " vertex " << v;
      if (r.status == ProjectStatus::feasible) continue;
      ++expect.violated;
      expect.projected += r.status == ProjectStatus::projected;
      expect.halted += r.status == ProjectStatus::halted;
      expect.infeasible += r.status == ProjectStatus::infeasible;
      expect.iterations += r.iterations;
      expect.remaining += !(min_value(anchor[i], r.x, regions.of(v)) >= -1e-9);
    }
    EXPECT_GT(s.violated, 500) << name;
    EXPECT_EQ(s.violated, expect.violated) << name;
    EXPECT_EQ(s.projected, expect.projected) << name;
    EXPECT_EQ(s.halted, expect.halted) << name;
    EXPECT_EQ(s.infeasible, expect.infeasible) << name;
    EXPECT_EQ(s.iterations, expect.iterations) << name;
    EXPECT_EQ(s.remaining, expect.remaining) << name;
    if (name != "successive_projection") EXPECT_EQ(s.remaining, 0) << name;
    Positions again = cand;
    project_all(*proj, regions, anchor, again, inv_mass);
    EXPECT_EQ(again, x) << name;
  }
}

TEST(ProjectAll, EmptyInverseMassMeansAllDynamicAndSizesAreChecked) {
  RegionSet regions;
  regions.clear(2);
  Positions anchor(2, Vec3::Zero()), x(2, Vec3::Ones());
  const auto proj = make_projector("plesnik");
  const BatchStats s = project_all(*proj, regions, anchor, x, {});
  EXPECT_EQ(s.violated, 0);
  EXPECT_EQ(x[0], Vec3::Ones());
  Positions short_x(1);
  EXPECT_THROW(project_all(*proj, regions, anchor, short_x, {}), std::invalid_argument);
}

}  // namespace
}  // namespace ccfr
