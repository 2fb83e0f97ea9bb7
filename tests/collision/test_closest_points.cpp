// ClosestPoints (collision/src/sub_pairs.hpp), the one closest-point implementation behind the
// initial pass and every detection pass: its distances against brute force over dense samples of
// both primitives, its weights against its closest points, and its canonical orientation, on
// degenerate input (parallel and collinear edges, zero-length edges, zero-area triangles,
// coincident points) and random pairs.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <tuple>
#include <vector>

#include "sub_pairs.hpp"

namespace ccfr {
namespace {

struct Record {
  ContactKind kind;
  Index a, b;
  std::array<Index, 4> v;
  std::array<double, 4> w;
  Vec3 pa, pb;
  double dist;
};

/// Records every sub-pair within `r`, as the initial pass does (no exclusion, no far culling).
struct RecordPolicy {
  static constexpr bool kCullFar = false;
  double r = 1e3;
  std::vector<Record> out;
  double pair_reach(ContactKind, const std::array<Index, 4>&) const { return r; }
  bool admit(ContactKind, Index, Index, Index& slot) const {
    slot = -2;
    return true;
  }
  double accept(ContactKind, Index, Index, Index, const std::array<Index, 4>&, double dist_sq) const {
    return dist_sq < r * r ? std::sqrt(dist_sq) : -1.0;
  }
  void emit(ContactKind kind, Index a, Index b, Index, const std::array<Index, 4>& v, const std::array<double, 4>& w,
            const Vec3& pa, const Vec3& pb, double dist) {
    out.push_back({kind, a, b, v, w, pa, pb, dist});
  }
};

/// Vertices 0-2: triangle 0 and edges 0 (0-1), 1 (1-2); vertices 3-5: triangle 1, edges 2 (3-4),
/// 3 (4-5); vertex 6 a point.
struct Scene {
  Topology topo;
  Positions x;
  explicit Scene(Positions pos) : x(std::move(pos)) {
    topo.faces = {Vec3i(0, 1, 2), Vec3i(3, 4, 5)};
    topo.edges = {Vec2i(0, 1), Vec2i(1, 2), Vec2i(3, 4), Vec2i(4, 5)};
  }
  Record run(void (detail::ClosestPoints<RecordPolicy>::*fn)(Index, Index), Index a, Index b) {
    detail::ClosestPoints<RecordPolicy> cp{topo, x, RecordPolicy{}};
    (cp.*fn)(a, b);
    EXPECT_EQ(cp.policy.out.size(), 1u);
    return cp.policy.out.empty() ? Record{} : cp.policy.out[0];
  }
};

constexpr int kSamples = 300;

Vec3 on_triangle(const Vec3& a, const Vec3& b, const Vec3& c, int i, int j) {
  const double u = double(i) / kSamples, v = double(j) / kSamples;
  return (1.0 - u - v) * a + u * b + v * c;
}
Vec3 on_segment(const Vec3& a, const Vec3& b, int i) { return a + (double(i) / kSamples) * (b - a); }

/// Brute force: the smallest sampled distance (an upper bound within one sample spacing).
double brute_vf(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= kSamples; ++i)
    for (int j = 0; i + j <= kSamples; ++j) best = std::min(best, (p - on_triangle(a, b, c, i, j)).norm());
  return best;
}
double brute_ee(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1) {
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= kSamples; ++i)
    for (int j = 0; j <= kSamples; ++j) best = std::min(best, (on_segment(a0, a1, i) - on_segment(b0, b1, j)).norm());
  return best;
}
double brute_ve(const Vec3& p, const Vec3& a, const Vec3& b) {
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= kSamples; ++i) best = std::min(best, (p - on_segment(a, b, i)).norm());
  return best;
}

/// The record is consistent: |pa − pb| is the distance, Σ w_k x_k = pa − pb, side A's weights sum
/// to 1 and side B's to −1, and the distance is the brute force's within one sample spacing.
void expect_consistent(const Record& r, const Positions& x, double brute, double extent) {
  EXPECT_NEAR((r.pa - r.pb).norm(), r.dist, 1e-12 * (1.0 + extent));
  const int na = detail::side_a_size(r.kind), n = detail::sub_pair_size(r.kind);
  Vec3 sum = Vec3::Zero();
  double wa = 0.0, wb = 0.0;
  for (int k = 0; k < n; ++k) {
    sum += r.w[k] * x[r.v[k]];
    (k < na ? wa : wb) += r.w[k];
    EXPECT_LE(std::abs(r.w[k]), 1.0 + 1e-12);
  }
  EXPECT_NEAR(wa, 1.0, 1e-12);
  EXPECT_NEAR(wb, -1.0, 1e-12);
  EXPECT_NEAR((sum - (r.pa - r.pb)).norm(), 0.0, 1e-12 * (1.0 + extent));
  EXPECT_LE(r.dist, brute + 1e-12);
  EXPECT_GE(r.dist, brute - 2.0 * extent / kSamples);
}

using CP = detail::ClosestPoints<RecordPolicy>;

void check_all(Scene& s, double extent) {
  const Positions& x = s.x;
  const Record vf = s.run(&CP::vf, 6, 0);
  expect_consistent(vf, x, brute_vf(x[6], x[0], x[1], x[2]), extent);
  const Record ee = s.run(&CP::ee, 0, 2);
  expect_consistent(ee, x, brute_ee(x[0], x[1], x[3], x[4]), extent);
  const Record ve = s.run(&CP::ve, 6, 2);
  expect_consistent(ve, x, brute_ve(x[6], x[3], x[4]), extent);
  const Record vv = s.run(&CP::vv, 6, 3);
  expect_consistent(vv, x, (x[6] - x[3]).norm(), extent);
  // Canonical orientation: the same record, bit for bit, whichever primitive comes first.
  for (auto [fn, a, b] : {std::tuple{&CP::ee, Index{0}, Index{2}}, std::tuple{&CP::vv, Index{6}, Index{3}}}) {
    const Record r1 = s.run(fn, a, b), r2 = s.run(fn, b, a);
    EXPECT_EQ(r1.a, r2.a);
    EXPECT_EQ(r1.b, r2.b);
    EXPECT_EQ(r1.v, r2.v);
    EXPECT_EQ(r1.w, r2.w);
    EXPECT_EQ(r1.dist, r2.dist);
  }
}

TEST(ClosestPoints, ParallelEdges) {
  Scene s({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0.5, 0.1, 0}, {1.5, 0.1, 0}, {2.5, 0.1, 0}, {0.7, 0.3, 0.2}});
  check_all(s, 3.0);
  const Record ee = s.run(&CP::ee, 0, 2);
  EXPECT_NEAR(ee.dist, 0.1, 1e-14);
}

TEST(ClosestPoints, CollinearOverlappingEdges) {
  Scene s({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0.5, 0, 0}, {1.5, 0, 0}, {2, 1, 0}, {0.25, 0, 0}});
  check_all(s, 2.0);
  EXPECT_EQ(s.run(&CP::ee, 0, 2).dist, 0.0);
  EXPECT_EQ(s.run(&CP::ve, 6, 2).dist, 0.25);
}

TEST(ClosestPoints, ZeroAreaTriangles) {
  // Collinear vertices, then two coincident vertices.
  Scene s({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0.5, 0.4, 0.3}, {0.5, 0.4, 0.3}, {1, 1, 1}, {0.5, 0.2, 0.1}});
  check_all(s, 3.0);
  Scene t({{0, 0, 0}, {0, 0, 0}, {1, 1, 0}, {3, 3, 3}, {4, 3, 3}, {3, 4, 3}, {0.2, -0.3, 0.5}});
  check_all(t, 6.0);
}

TEST(ClosestPoints, CoincidentPoints) {
  Scene s({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}, {1, 0, 0}, {0, 0, 1}, {1, 0, 0}});
  check_all(s, 2.0);
  EXPECT_EQ(s.run(&CP::vf, 6, 0).dist, 0.0);  // on a triangle vertex
  EXPECT_EQ(s.run(&CP::vv, 6, 3).dist, 0.0);
  EXPECT_EQ(s.run(&CP::ve, 6, 2).dist, 0.0);  // on a zero-length edge
}

TEST(ClosestPoints, RandomPairs) {
  std::mt19937 rng(57);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 40; ++trial) {
    Positions x(7);
    for (Vec3& p : x) p = Vec3(u(rng), u(rng), u(rng));
    Scene s(x);
    check_all(s, 4.0);
  }
}

TEST(ClosestPoints, BoxPreCheckDropsOnlyFarPairs) {
  Scene s({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 2}, {1, 0, 2}, {0, 1, 2}, {0.2, 0.2, 2}});
  CP cp{s.topo, s.x, RecordPolicy{}};
  RecordPolicy& policy = cp.policy;
  policy.r = 1.5;  // below the sub-pairs' distance of 2
  cp.vf(6, 0);
  cp.ee(0, 2);
  EXPECT_TRUE(policy.out.empty());
  policy.r = 2.0 + 1e-9;
  cp.vf(6, 0);
  cp.ee(0, 2);
  ASSERT_EQ(policy.out.size(), 2u);
  EXPECT_NEAR(policy.out[0].dist, 2.0, 1e-15);
  EXPECT_NEAR(policy.out[1].dist, 2.0, 1e-15);
}

}  // namespace
}  // namespace ccfr
