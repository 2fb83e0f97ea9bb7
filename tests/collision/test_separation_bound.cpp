// separation_lower_bound: the violation recount skips the distance kernel for every contact whose
// bound along its detection normal already clears the offset, so the bound must never exceed the
// true distance. Checked against a long-double evaluation of the same projection gap (which the
// true distance bounds from above) and against closed-form distances where the bound is tight,
// for every pair kind, random normals, far-from-origin coordinates and degenerate input.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "ccfr/collision/collision_detector.hpp"

namespace ccfr {
namespace {

using LD = long double;

/// The projection gap (min over A of n·p - max over B of n·p) / |n| in long double.
LD gap_ld(const ContactPair& c, const Positions& x) {
  const LD nx = c.n.x(), ny = c.n.y(), nz = c.n.z();
  const LD len = std::sqrt(nx * nx + ny * ny + nz * nz);
  LD lo = std::numeric_limits<LD>::infinity(), hi = -lo;
  for (int k = 0; k < c.size(); ++k) {
    const Vec3& p = x[c.v[k]];
    const LD along = (nx * LD(p.x()) + ny * LD(p.y()) + nz * LD(p.z())) / len;
    if (k < c.side_a())
      lo = std::min(lo, along);
    else
      hi = std::max(hi, along);
  }
  return lo - hi;
}

ContactPair pair_of(ContactKind kind, const Vec3& n) {
  ContactPair c;
  c.kind = kind;
  for (int k = 0; k < c.size(); ++k) c.v[k] = k;
  c.n = n;
  return c;
}

TEST(SeparationLowerBound, NeverExceedsTheProjectionGapForAnyKindOrNormal) {
  std::mt19937_64 rng(20261124);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const ContactKind kinds[] = {ContactKind::vf, ContactKind::ee, ContactKind::ve, ContactKind::vv};
  int tight = 0;
  for (int trial = 0; trial < 200000; ++trial) {
    // Coordinates near the origin and 1e4 away from it (the margin scales with the magnitude).
    const double shift = trial % 2 ? 1e4 : 0.0, size = trial % 3 == 0 ? 1e-3 : 0.05;
    Positions x(4);
    for (auto& p : x) p = Vec3(shift + size * u(rng), -shift + size * u(rng), size * u(rng));
    if (trial % 5 == 0) x[1] = x[0];                 // coincident points
    if (trial % 7 == 0) x[3] = 0.5 * (x[1] + x[2]);  // zero-area triangle / collinear
    Vec3 n(u(rng), u(rng), u(rng));
    n.normalize();
    const ContactPair c = pair_of(kinds[trial % 4], n);
    const double lb = separation_lower_bound(c, x);
    const LD ref = gap_ld(c, x);
    ASSERT_LE(LD(lb), ref) << "trial " << trial;
    // The recount's form: one scale for the whole scene, here its extent 1e4 + 1 or 1 (at least
    // each vertex's |p|_1, as the contract requires). Looser by a few ulps of it, never above.
    const double scene = 3.0 * (shift + 1.0), lb_scene = separation_lower_bound(c, x, scene);
    ASSERT_LE(lb_scene, lb) << "trial " << trial;
    ASSERT_GT(lb_scene, lb - 1e-12 * (1.0 + shift)) << "trial " << trial;
    tight += ref - LD(lb) < 1e-12L * (1.0L + shift);
  }
  EXPECT_GT(tight, 190000);  // the margin is a few ulps, not a loss of the bound
}

TEST(SeparationLowerBound, EqualsTheDistanceOfAVertexAboveAFaceAndOfParallelEdges) {
  // Vertex 3 mm above the interior of a triangle, normal along the face normal: the bound is the
  // distance itself, less the margin.
  Positions x{{0.1, 0.2, 0.003}, {0.0, 0.0, 0.0}, {0.5, 0.0, 0.0}, {0.0, 0.5, 0.0}};
  const ContactPair vf = pair_of(ContactKind::vf, Vec3::UnitZ());
  EXPECT_LE(separation_lower_bound(vf, x), 0.003);
  EXPECT_NEAR(separation_lower_bound(vf, x), 0.003, 1e-13);
  // Two parallel edges 2 mm apart (side A above): every point pair is a closest pair.
  Positions e{{0.0, 0.0, 0.002}, {1.0, 0.0, 0.002}, {0.2, 0.0, 0.0}, {0.7, 0.0, 0.0}};
  const ContactPair ee = pair_of(ContactKind::ee, Vec3::UnitZ());
  EXPECT_LE(separation_lower_bound(ee, e), 0.002);
  EXPECT_NEAR(separation_lower_bound(ee, e), 0.002, 1e-13);  // margin: 64 ulps of |p|_1 = 1
  // A tilted normal gives less than the distance, never more: cos(30 deg) of it.
  const ContactPair tilted = pair_of(ContactKind::ee, Vec3(0.0, std::sin(M_PI / 6), std::cos(M_PI / 6)));
  EXPECT_LE(separation_lower_bound(tilted, e), 0.002 * std::cos(M_PI / 6) + 1e-15);
}

TEST(SeparationLowerBound, IsNegativeForCrossedOrTouchingPairsAndNaNForNaN) {
  // Vertex below the face it was detected above (d < 0): the pair has crossed.
  Positions x{{0.1, 0.1, -0.001}, {0.0, 0.0, 0.0}, {0.5, 0.0, 0.0}, {0.0, 0.5, 0.0}};
  const ContactPair vf = pair_of(ContactKind::vf, Vec3::UnitZ());
  EXPECT_LT(separation_lower_bound(vf, x), 0.0);
  // Coincident vertices: distance 0, the bound at most 0.
  Positions v{{0.3, 0.3, 0.3}, {0.3, 0.3, 0.3}};
  EXPECT_LE(separation_lower_bound(pair_of(ContactKind::vv, Vec3::UnitX()), v), 0.0);
  for (int k = 0; k < 4; ++k) {
    Positions bad = x;
    bad[k].y() = std::numeric_limits<double>::quiet_NaN();
    EXPECT_TRUE(std::isnan(separation_lower_bound(vf, bad))) << "vertex " << k;
    // The recount's form with one scene scale, finite or (as its loop gives for a NaN) NaN.
    EXPECT_TRUE(std::isnan(separation_lower_bound(vf, bad, 10.0))) << "vertex " << k;
    EXPECT_TRUE(std::isnan(separation_lower_bound(vf, bad, std::nan("")))) << "vertex " << k;
  }
  Positions inf = x;
  inf[2].x() = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(separation_lower_bound(vf, inf) >= 0.0);  // never a clearance from an infinite vertex
  const double infinite = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(separation_lower_bound(vf, inf, infinite) >= 0.0);
  Positions up = x;  // a vertex at +infinity along the normal, on side A
  up[0].z() = infinite;
  EXPECT_FALSE(separation_lower_bound(vf, up, infinite) >= 0.0);
  EXPECT_FALSE(separation_lower_bound(vf, up, 10.0) >= 0.0);
}

}  // namespace
}  // namespace ccfr
