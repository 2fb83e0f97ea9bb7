// The separating-plane guarantee when one side is scripted (kinematic) and moves by a known step
// in the coming iteration: rotations included, where a closest-point bound is not enough.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/geometry/distance.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {
constexpr double kXi = 0.01, kR = 0.005;

/// Random rigid step of the triangle: rotation about a random axis through a random point near it,
/// plus a translation, scaled so that no vertex moves more than `max_step`.
std::vector<Vec3> rigid_step(std::mt19937_64& g, const std::vector<Vec3>& tri, double max_step) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Vec3 axis = Vec3(u(g), u(g), u(g)).normalized();
  const Vec3 centre = tri[0] + Vec3(u(g), u(g), u(g)) * 0.05;
  const Eigen::AngleAxisd rot(0.2 * u(g), axis);
  const Vec3 shift = Vec3(u(g), u(g), u(g)) * 0.002;
  std::vector<Vec3> step;
  double largest = 0.0;
  for (const auto& p : tri) {
    step.push_back(centre + rot * (p - centre) + shift - p);
    largest = std::max(largest, step.back().norm());
  }
  if (largest > max_step)
    for (auto& s : step) s *= max_step / largest;
  return step;
}

/// A random move within the ball of radius r that satisfies every half-space of `planes`.
bool admissible_move(std::mt19937_64& g, std::span<const HalfSpace> planes, Vec3& move) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int attempt = 0; attempt < 200; ++attempt) {
    const Vec3 m = Vec3(u(g), u(g), u(g)) * kR;
    if (m.norm() > kR) continue;
    bool ok = true;
    for (const auto& h : planes) ok = ok && h.n.dot(m) + h.d >= 0.0;
    if (ok) {
      move = m;
      return true;
    }
  }
  return false;
}
}  // namespace

TEST(KinematicStep, RotatingTriangleKeepsParticlesAndSegmentsBeyondXi) {
  auto g = ccfr::test::rng(404);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int checked = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const std::vector<Vec3> tri{{0, 0, 0}, {0.08, 0, 0}, {0, 0, 0.08}};
    TopologyBuilder tb;
    tb.add_object("plate", ObjectKind::obstacle, 3, {{0, 2, 1}});
    const bool segment = trial % 2 == 1;
    if (segment)
      tb.add_object("wire", ObjectKind::strand, 2, {}, {}, {{0, 1}});
    else
      tb.add_object("grain", ObjectKind::particles, 1);
    const Topology topo = tb.finish();
    Positions x(tri.begin(), tri.end());
    const Vec3 above(0.06 * u(g), kXi + 2 * kR * u(g), 0.06 * u(g));
    x.push_back(above);
    if (segment) x.push_back(above + Vec3(0.03 * (u(g) - 0.5), 0.01 * u(g), 0.03 * (u(g) - 0.5)));
    std::vector<double> w(x.size(), 1.0);
    w[0] = w[1] = w[2] = 0.0;
    Positions step(x.size(), Vec3::Zero());
    const auto s = rigid_step(g, tri, kR);
    for (int k = 0; k < 3; ++k) step[k] = s[k];

    CollisionDetector det(topo, x, {kR, kXi, 0.0}, make_broad_phase("brute_force"));
    RegionSet regions;
    std::vector<ContactPair> contacts;
    DetectionStats stats;
    det.detect(x, w, regions, contacts, stats, step);
    bool feasible_anchor = true;
    for (Index v = 3; v < static_cast<Index>(x.size()); ++v)
      for (const auto& h : regions.of(v)) feasible_anchor = feasible_anchor && h.d >= 0.0;
    if (!feasible_anchor) continue;  // the obstacle closes in faster than the gap: d < 0 (clarification 7)

    Positions y = x;
    bool moved = true;
    for (int k = 0; k < 3; ++k) y[k] += step[k];
    for (Index v = 3; v < static_cast<Index>(x.size()); ++v) {
      Vec3 m;
      moved = moved && admissible_move(g, regions.of(v), m);
      y[v] += m;
    }
    if (!moved) continue;
    const double d =
        segment
            ? std::sqrt(std::min(
                  {edge_edge(y[3], y[4], y[0], y[1]).distance_sq, edge_edge(y[3], y[4], y[1], y[2]).distance_sq,
                   edge_edge(y[3], y[4], y[2], y[0]).distance_sq, point_triangle(y[3], y[0], y[1], y[2]).distance_sq,
                   point_triangle(y[4], y[0], y[1], y[2]).distance_sq}))
            : std::sqrt(point_triangle(y[3], y[0], y[1], y[2]).distance_sq);
    EXPECT_GE(d, kXi - 1e-9) << "trial " << trial << (segment ? " (segment)" : " (particle)");
    ++checked;
  }
  EXPECT_GT(checked, 1500);
}
