// Additive CCD (collision/additive_ccd.hpp) against closed-form and densely sampled times of impact.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <random>

#include "ccfr/collision/additive_ccd.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {

using Stencil = std::array<Vec3, 4>;

/// First sample time in [0, 1] at which the linearly moving stencil is within ξ (2 if none), and
/// the smallest distance seen over the samples in [0, t_max].
struct Sampled {
  double first_contact = 2.0;
  double min_distance_before = std::numeric_limits<double>::infinity();
};
Sampled sample_path(ContactKind kind, const Stencil& x0, const Stencil& x1, double xi, double t_max, int samples) {
  Sampled out;
  for (int i = 0; i <= samples; ++i) {
    const double t = static_cast<double>(i) / samples;
    Stencil xt;
    for (int k = 0; k < 4; ++k) xt[k] = x0[k] + t * (x1[k] - x0[k]);
    const double d = sub_pair_distance(kind, xt);
    if (t <= t_max) out.min_distance_before = std::min(out.min_distance_before, d);
    if (d <= xi && out.first_contact > 1.0) out.first_contact = t;
  }
  return out;
}

}  // namespace

TEST(AdditiveCcd, PointTowardTriangleMatchesTheClosedFormWithinTheScale) {
  // A point falling onto the plane z = 0 inside the triangle: d(t) = d0 - t v_n, so the gap
  // reaches zero at t = (d0 - ξ) / v_n. Head-on, Additive CCD lands at exactly s times that.
  const double xi = 0.01;
  const Stencil tri{Vec3(0.2, 0.2, 0.05), Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  for (double vn : {0.02, 0.05, 0.1, 1.0}) {
    Stencil x1 = tri;
    x1[0] -= Vec3(0, 0, vn);
    const double t_true = (0.05 - xi) / vn;
    for (double s : {0.5, 0.9, 0.99}) {
      const AccdResult r = additive_ccd(ContactKind::vf, tri, x1, xi, {s, 1000, 1e-12});
      if (t_true > 1.0) {
        EXPECT_EQ(r.toi, 1.0) << vn;
        EXPECT_FALSE(r.impact);
        continue;
      }
      EXPECT_TRUE(r.impact);
      EXPECT_NEAR(r.toi, s * t_true, 1e-12) << "v_n " << vn << " s " << s;
      EXPECT_LE(r.toi, t_true);
    }
  }
  // With a tangential component the bound l_p = |p| exceeds the approach rate v_n: more, smaller
  // steps. The answer t keeps g(t) >= (1 - s) g0 while the dropped step s g(t) / l_p would have gone
  // below it, so for a plane t_true (1 - (1 - s) / (1 - s v_n / l_p)) < t <= s t_true.
  const Vec3 p(0.1, 0.05, -0.06);
  Stencil x1 = tri;
  x1[0] += p;
  const double t_true = (0.05 - xi) / 0.06, s = 0.9, ratio = 0.06 / p.norm();
  const AccdResult r = additive_ccd(ContactKind::vf, tri, x1, xi, {s, 1000, 1e-12});
  EXPECT_LE(r.toi, s * t_true + 1e-12);
  EXPECT_GT(r.toi, t_true * (1.0 - (1.0 - s) / (1.0 - s * ratio)));
  EXPECT_GT(r.iterations, 2);
}

TEST(AdditiveCcd, EdgeTowardEdgeMatchesTheClosedForm) {
  // Crossing edges, one moving straight toward the other along their common normal, while both
  // translate together (the mean displacement is removed and must not slow the search).
  const double xi = 0.01;
  const Vec3 drift(0.3, -0.2, 0.1);
  const Stencil x0{Vec3(-1, 0, 0.1), Vec3(1, 0, 0.1), Vec3(0, -1, 0), Vec3(0, 1, 0)};
  Stencil x1 = x0;
  for (int k = 0; k < 4; ++k) x1[k] += drift;
  x1[0].z() -= 0.15;
  x1[1].z() -= 0.15;
  const double t_true = (0.1 - xi) / 0.15;
  const AccdResult r = additive_ccd(ContactKind::ee, x0, x1, xi, {0.9, 1000, 1e-12});
  EXPECT_TRUE(r.impact);
  EXPECT_NEAR(r.toi, 0.9 * t_true, 1e-12);
  // Exact in the limit of s -> 1.
  const AccdResult fine = additive_ccd(ContactKind::ee, x0, x1, xi, {0.999999, 100000, 1e-12});
  EXPECT_NEAR(fine.toi, t_true, 1e-5);
  EXPECT_LE(fine.toi, t_true);
  // Parallel edges sliding along each other at constant distance: no impact.
  const Stencil p0{Vec3(0, 0, 0.02), Vec3(1, 0, 0.02), Vec3(0, 0, 0), Vec3(1, 0, 0)};
  Stencil p1 = p0;
  p1[0].x() += 0.5;
  p1[1].x() += 0.5;
  EXPECT_EQ(additive_ccd(ContactKind::ee, p0, p1, xi).toi, 1.0);
}

TEST(AdditiveCcd, PairsAtOrInsideTheOffsetGetZero) {
  const Stencil x0{Vec3(0.2, 0.2, 0.01), Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  Stencil away = x0;
  away[0].z() += 0.1;
  EXPECT_EQ(additive_ccd(ContactKind::vf, x0, away, 0.01).toi, 0.0);
  EXPECT_EQ(additive_ccd(ContactKind::vf, x0, away, 0.02).toi, 0.0);
}

TEST(AdditiveCcd, NeverLaterThanTheSampledTimeOfImpactOnRandomMotions) {
  auto rng = ccfr::test::rng(20231);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const double xi = 0.05;
  int impacts = 0;
  for (ContactKind kind : {ContactKind::vf, ContactKind::ee, ContactKind::ve, ContactKind::vv}) {
    for (int trial = 0; trial < 300; ++trial) {
      Stencil x0, x1;
      const int n = kind == ContactKind::vf || kind == ContactKind::ee ? 4 : (kind == ContactKind::ve ? 3 : 2);
      const int na = kind == ContactKind::ee ? 2 : 1;
      // Side A above side B, each side a small primitive; motions large enough to collide often.
      for (int k = 0; k < 4; ++k) {
        const Vec3 centre = k < na ? Vec3(0, 0, 0.3) : Vec3(0, 0, 0);
        x0[k] = k < n ? Vec3(centre + 0.3 * Vec3(U(rng), U(rng), 0.3 * U(rng))) : Vec3::Zero();
        x1[k] = k < n ? Vec3(x0[k] + 0.4 * Vec3(U(rng), U(rng), U(rng)) + (k < na ? -0.4 : 0.2) * Vec3::UnitZ())
                      : Vec3::Zero();
      }
      if (sub_pair_distance(kind, x0) <= xi) continue;
      const AccdResult r = additive_ccd(kind, x0, x1, xi, {0.9, 1000, 1e-12});
      const Sampled sm = sample_path(kind, x0, x1, xi, r.toi, 4000);
      EXPECT_LE(r.toi, sm.first_contact) << to_string(kind) << " trial " << trial;
      EXPECT_GT(sm.min_distance_before, xi) << to_string(kind) << " trial " << trial;
      if (sm.first_contact <= 1.0) {
        ++impacts;
        EXPECT_TRUE(r.impact);
      }
    }
  }
  EXPECT_GT(impacts, 150) << "the random motions were meant to collide often";
}
