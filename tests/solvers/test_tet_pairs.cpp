// The tets' sweep solves two tets of one colour side by side (TetBatch::solve_in_order,
// polar_rotation_newton of two matrices). That must be the same computation as one tet at a time:
// these tests compare bit for bit against the one-tet kernels, including the degenerate tets
// (inverted, flat, at rest) and orders where consecutive tets share a vertex.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <random>
#include <vector>

#include "ccfr/solvers/material_constraint.hpp"
#include "ccfr/solvers/materials/tet_elasticity.hpp"
#include "ccfr/solvers/polar_decomposition.hpp"
#include "test_support.hpp"

namespace ccfr {
namespace {

using Mat3 = Eigen::Matrix3d;

bool same_bits(const Mat3& a, const Mat3& b) { return std::memcmp(a.data(), b.data(), sizeof(double) * 9) == 0; }

Mat3 random_rotation(std::mt19937_64& g) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Quaterniond q(n(g), n(g), n(g), n(g));
  q.normalize();
  return q.toRotationMatrix();
}

/// A matrix of kind k: mild, moderate and large strain (the scaled and unscaled steps), inverted,
/// flat, zero, and an exact rotation (converges in one step). No NaN: Eigen's SVD, the fallback,
/// returns arbitrary values for one (two calls on the same NaN matrix differ), and the tet kernels
/// skip a non-finite F before they decompose it.
Mat3 matrix_of_kind(int k, std::mt19937_64& g) {
  Mat3 a = random_rotation(g) * (Mat3::Identity() + (k == 0 ? 1e-5 : k == 1 ? 0.02 : 0.8) * Mat3::Random());
  if (k == 3) a.col(1) = -a.col(1);
  if (k == 4) a.col(2) = 0.5 * a.col(0) - 0.25 * a.col(1);
  if (k == 5) a = Mat3::Zero();
  if (k == 6) a = random_rotation(g);
  return a;
}

TEST(PolarRotation, NewtonOfTwoMatricesIsBitIdenticalToTwoCalls) {
  auto g = test::rng(91);
  int pairs = 0;
  for (int trial = 0; trial < 50; ++trial)
    for (int ka = 0; ka < 7; ++ka)
      for (int kb = 0; kb < 7; ++kb) {
        const Mat3 a = matrix_of_kind(ka, g), b = matrix_of_kind(kb, g);
        Mat3 ra, rb;
        xpbd::polar_rotation_newton(a, b, ra, rb);
        ASSERT_TRUE(same_bits(ra, xpbd::polar_rotation_newton(a))) << "kinds " << ka << ", " << kb << "\n" << a;
        ASSERT_TRUE(same_bits(rb, xpbd::polar_rotation_newton(b))) << "kinds " << ka << ", " << kb << "\n" << b;
        ++pairs;
      }
  EXPECT_EQ(pairs, 50 * 7 * 7);
  // One of a pair converging steps before the other keeps its own result: a rotation (one step)
  // beside a large strain (several), against the SVD as an independent answer.
  const Mat3 rot = random_rotation(g), strained = rot * Eigen::Vector3d(3.0, 0.5, 1.2).asDiagonal();
  Mat3 r1, r2;
  xpbd::polar_rotation_newton(rot, strained, r1, r2);
  EXPECT_LT((r1 - rot).norm(), 1e-14);
  EXPECT_LT((r2 - rot).norm(), 1e-13);
  EXPECT_LT((r2 - xpbd::polar_rotation(strained)).norm(), 1e-13);
}

/// Tets of an n^3 grid of cubes, six per cube (Kuhn), over (n + 1)^3 vertices of spacing h.
struct TetGrid {
  Positions rest;
  std::vector<Vec4i> tets;
};

TetGrid tet_grid(int n, double h) {
  TetGrid grid;
  const int m = n + 1;
  auto id = [m](int i, int j, int k) { return (i * m + j) * m + k; };
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j)
      for (int k = 0; k < m; ++k) grid.rest.emplace_back(h * i, h * j, h * k);
  // The six paths from corner 0 to corner 7 of a cube, one tet each.
  const int paths[6][2] = {{1, 2}, {1, 4}, {2, 1}, {2, 4}, {4, 1}, {4, 2}};
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) {
        auto corner = [&](int bits) { return id(i + (bits >> 2 & 1), j + (bits >> 1 & 1), k + (bits & 1)); };
        for (const auto& p : paths) grid.tets.push_back(Vec4i(corner(0), corner(p[0]), corner(p[0] | p[1]), corner(7)));
      }
  return grid;
}

TEST(TetBatch, SolveInOrderIsBitIdenticalToOneTetAtATime) {
  const TetGrid grid = tet_grid(3, 0.1);
  const Index nv = static_cast<Index>(grid.rest.size());
  TetBatch batch;
  for (const Vec4i& t : grid.tets) ASSERT_TRUE(batch.add(t, grid.rest, 1e-7, 1e-6));
  const Index nt = static_cast<Index>(batch.ids.size());

  auto g = test::rng(17);
  std::uniform_real_distribution<double> u(-0.02, 0.02);
  std::vector<double> w(static_cast<size_t>(nv), 1.0);
  for (Index v = 0; v < nv; v += 7) w[static_cast<size_t>(v)] = 0.0;  // pinned vertices
  Positions start = grid.rest;
  for (Vec3& p : start) p += Vec3(u(g), u(g), u(g));
  // Degenerate tets: the first flattened onto a plane, the second inverted, the last left at rest.
  const Vec4i& flat = batch.ids[0];
  start[flat[3]] = start[flat[0]] + 0.3 * (start[flat[1]] - start[flat[0]]) + 0.3 * (start[flat[2]] - start[flat[0]]);
  const Vec4i& inverted = batch.ids[nt / 2];
  std::swap(start[inverted[1]], start[inverted[2]]);

  std::vector<Index> flat_ids;
  for (const Vec4i& t : batch.ids) flat_ids.insert(flat_ids.end(), {t[0], t[1], t[2], t[3]});
  const Colouring colouring = colour_constraints(nv, flat_ids, 4, w);
  std::vector<Index> identity(static_cast<size_t>(nt)), shuffled(static_cast<size_t>(nt));
  std::iota(identity.begin(), identity.end(), 0);
  std::iota(shuffled.begin(), shuffled.end(), 0);
  std::shuffle(shuffled.begin(), shuffled.end(), g);

  const double dt = 1.0 / 240.0, inv_dt2 = 1.0 / (dt * dt);
  int orders_with_pairs = 0;
  for (const std::vector<Index>* order :
       std::vector<const std::vector<Index>*>{&colouring.order, &identity, &shuffled}) {
    // Consecutive tets without a common vertex: the pairs solve_in_order runs side by side.
    int disjoint = 0;
    for (size_t k = 0; k + 1 < order->size(); ++k) {
      const Vec4i &a = batch.ids[(*order)[k]], &b = batch.ids[(*order)[k + 1]];
      bool shared = false;
      for (int i = 0; i < 4; ++i) shared = shared || (b.array() == a[i]).any();
      disjoint += !shared;
    }
    orders_with_pairs += disjoint > 0;

    Positions x = start, ref = start;
    TetBatch reference = batch;
    batch.reset_multipliers();
    reference.reset_multipliers();
    for (int sweep = 0; sweep < 3; ++sweep) {
      batch.solve_in_order(*order, x, w, dt);
      for (const Index c : *order) {
        const Vec4i& v = reference.ids[c];
        const std::array<Vec3*, 4> p{&ref[v[0]], &ref[v[1]], &ref[v[2]], &ref[v[3]]};
        const std::array<double, 4> wv{w[v[0]], w[v[1]], w[v[2]], w[v[3]]};
        xpbd::solve_tet_deviatoric(p, wv, reference.rest_inverse[c], reference.deviatoric_compliance[c] * inv_dt2,
                                   reference.lambda_deviatoric[c]);
        xpbd::solve_tet_volume(p, wv, reference.rest_volume[c], reference.volume_compliance[c] * inv_dt2,
                               reference.lambda_volume[c]);
      }
    }
    for (Index v = 0; v < nv; ++v) ASSERT_EQ(x[v], ref[v]) << "vertex " << v << ", disjoint pairs " << disjoint;
    EXPECT_EQ(batch.lambda_deviatoric, reference.lambda_deviatoric);
    EXPECT_EQ(batch.lambda_volume, reference.lambda_volume);
    // The sweeps moved the vertices and left the pinned ones where they were.
    EXPECT_NE(x, start);
    for (Index v = 0; v < nv; v += 7) EXPECT_EQ(x[v], start[v]);
  }
  // The colour order pairs nearly everything; the grid's own order shares vertices throughout.
  EXPECT_GE(orders_with_pairs, 2);
}

}  // namespace
}  // namespace ccfr
