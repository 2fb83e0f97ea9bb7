// Tests of the XPBD material constraints: analytic gradients against finite differences, closed-form
// single steps, compliance, rigid-motion invariance, degenerate input, shape matching, colouring and
// thread-count determinism of MaterialSystem.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <random>
#include <set>
#include <stdexcept>
#include <string>

#include "ccfr/core/parallel.hpp"
#include "ccfr/core/state.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/solvers/material_system.hpp"
#include "ccfr/solvers/materials/dihedral_bending.hpp"
#include "ccfr/solvers/materials/strand_bending.hpp"
#include "ccfr/solvers/materials/stretch.hpp"
#include "ccfr/solvers/materials/tet_elasticity.hpp"
#include "ccfr/solvers/polar_decomposition.hpp"
#include "test_support.hpp"

namespace ccfr {
namespace {

using Mat3 = Eigen::Matrix3d;

Vec3 random_vec(std::mt19937_64& g, double scale = 1.0) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return Vec3(u(g), u(g), u(g));
}

Mat3 random_rotation(std::mt19937_64& g) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Quaterniond q(n(g), n(g), n(g), n(g));
  q.normalize();
  return q.toRotationMatrix();
}

/// Central finite-difference gradient of f with respect to each of the N points.
template <int N>
std::array<Vec3, N> fd_gradient(std::array<Vec3, N> x, const std::function<double(const std::array<Vec3, N>&)>& f,
                                double h = 1e-6) {
  std::array<Vec3, N> g;
  for (int k = 0; k < N; ++k)
    for (int d = 0; d < 3; ++d) {
      const double x0 = x[k][d];
      x[k][d] = x0 + h;
      const double fp = f(x);
      x[k][d] = x0 - h;
      const double fm = f(x);
      x[k][d] = x0;
      g[k][d] = (fp - fm) / (2.0 * h);
    }
  return g;
}

template <int N>
double max_abs_diff(const std::array<Vec3, N>& a, const std::array<Vec3, N>& b) {
  double m = 0.0;
  for (int k = 0; k < N; ++k) m = std::max(m, (a[k] - b[k]).cwiseAbs().maxCoeff());
  return m;
}

template <int N>
std::array<Vec3*, N> ptrs(std::array<Vec3, N>& x) {
  std::array<Vec3*, N> p;
  for (int k = 0; k < N; ++k) p[k] = &x[k];
  return p;
}

template <int N>
bool all_finite(const std::array<Vec3, N>& x) {
  for (const auto& v : x)
    if (!v.allFinite()) return false;
  return true;
}

/// A well-shaped bending stencil: edge along x, wings on either side, the second one lifted.
std::array<Vec3, 4> random_hinge(std::mt19937_64& g) {
  std::array<Vec3, 4> x{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.4, 0.8, 0), Vec3(0.6, -0.7, 0.3)};
  for (auto& v : x) v += random_vec(g, 0.15);
  return x;
}

std::array<Vec3, 4> random_tet(std::mt19937_64& g) {
  std::array<Vec3, 4> x{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  for (auto& v : x) v += random_vec(g, 0.2);
  return x;
}

Mat3 rest_inverse_of(const std::array<Vec3, 4>& r) {
  Mat3 dm;
  dm << r[1] - r[0], r[2] - r[0], r[3] - r[0];
  return dm.inverse();
}

// ---------------------------------------------------------------------------------------------
// Gradients against finite differences

/// The batch of the material constraint `name` as its type; fails the test when the scene has none.
template <class B>
const B& batch_of(const MaterialSystem& ms, std::string_view name) {
  const auto* b = dynamic_cast<const B*>(ms.batch(name));
  if (!b) throw std::runtime_error("no batch '" + std::string(name) + "' of that type");
  return *b;
}

TEST(MaterialGradients, DihedralAngleMatchesFiniteDifferences) {
  auto g = test::rng(11);
  for (int trial = 0; trial < 200; ++trial) {
    const auto x = random_hinge(g);
    double theta = 0.0;
    std::array<Vec3, 4> grad;
    ASSERT_TRUE(xpbd::dihedral_angle_gradient(x[0], x[1], x[2], x[3], theta, grad));
    EXPECT_NEAR(theta, xpbd::dihedral_angle(x[0], x[1], x[2], x[3]), 1e-14);
    const auto fd =
        fd_gradient<4>(x, [](const std::array<Vec3, 4>& p) { return xpbd::dihedral_angle(p[0], p[1], p[2], p[3]); });
    EXPECT_LT(max_abs_diff<4>(grad, fd), 1e-6) << "trial " << trial;
  }
}

TEST(MaterialGradients, DihedralAngleSignAndRange) {
  // Flat pair: 0. Lifting the second wing by h gives θ ≈ -h; a right-angle fold gives ±π/2.
  EXPECT_NEAR(xpbd::dihedral_angle(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, -1, 0)), 0.0, 1e-15);
  EXPECT_NEAR(xpbd::dihedral_angle(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, -1, 1e-4)), -1e-4, 1e-10);
  EXPECT_NEAR(std::abs(xpbd::dihedral_angle(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1))),
              std::numbers::pi / 2, 1e-14);
}

TEST(MaterialGradients, TurningAngleMatchesFiniteDifferences) {
  auto g = test::rng(12);
  for (int trial = 0; trial < 200; ++trial) {
    std::array<Vec3, 3> x{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1.8, 0.5, 0)};
    for (auto& v : x) v += random_vec(g, 0.3);
    double phi = 0.0;
    std::array<Vec3, 3> grad;
    ASSERT_TRUE(xpbd::turning_angle_gradient(x[0], x[1], x[2], phi, grad));
    EXPECT_NEAR(phi, xpbd::turning_angle(x[0], x[1], x[2]), 1e-14);
    const auto fd =
        fd_gradient<3>(x, [](const std::array<Vec3, 3>& p) { return xpbd::turning_angle(p[0], p[1], p[2]); });
    EXPECT_LT(max_abs_diff<3>(grad, fd), 1e-6) << "trial " << trial;
  }
  EXPECT_NEAR(xpbd::turning_angle(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0)), std::numbers::pi / 2, 1e-15);
}

TEST(MaterialGradients, TetVolumeMatchesFiniteDifferences) {
  auto g = test::rng(13);
  for (int trial = 0; trial < 100; ++trial) {
    const auto x = random_tet(g);
    std::array<Vec3, 4> grad;
    const double c = xpbd::tet_volume_constraint(x, 0.1, grad);
    EXPECT_NEAR(c, xpbd::tet_six_volume(x[0], x[1], x[2], x[3]) - 0.6, 1e-14);
    const auto fd = fd_gradient<4>(x, [](const std::array<Vec3, 4>& p) {
      std::array<Vec3, 4> unused;
      return xpbd::tet_volume_constraint(p, 0.1, unused);
    });
    EXPECT_LT(max_abs_diff<4>(grad, fd), 1e-7);
  }
}

TEST(MaterialGradients, TetDeviatoricMatchesFiniteDifferences) {
  auto g = test::rng(14);
  for (int trial = 0; trial < 100; ++trial) {
    const Mat3 dm_inv = rest_inverse_of(random_tet(g));
    const auto x = random_tet(g);
    double c = 0.0;
    std::array<Vec3, 4> grad;
    ASSERT_TRUE(xpbd::tet_deviatoric_constraint(x, dm_inv, c, grad));
    const auto fd = fd_gradient<4>(x, [&](const std::array<Vec3, 4>& p) {
      double cv = 0.0;
      std::array<Vec3, 4> unused;
      xpbd::tet_deviatoric_constraint(p, dm_inv, cv, unused);
      return cv;
    });
    EXPECT_LT(max_abs_diff<4>(grad, fd), 1e-6);
  }
}

// ---------------------------------------------------------------------------------------------
// Single steps: closed forms and compliance

TEST(MaterialSteps, TetVolumeWithOneDynamicVertexIsExactInOneStep) {
  // With x_0..x_2 kinematic, C_V is linear in x_3: one zero-compliance step solves it exactly, and
  // the step is the closed-form projection onto the plane 6V = 6V_0.
  auto g = test::rng(21);
  for (int trial = 0; trial < 50; ++trial) {
    auto x = random_tet(g);
    const double v0 = 0.25 + 0.1 * trial / 50.0;
    const Vec3 n = (x[1] - x[0]).cross(x[2] - x[0]);
    const Vec3 expect = x[3] - (n.dot(x[3] - x[0]) - 6.0 * v0) / n.squaredNorm() * n;
    double lambda = 0.0;
    xpbd::solve_tet_volume(ptrs<4>(x), {0.0, 0.0, 0.0, 2.0}, v0, 0.0, lambda);
    EXPECT_NEAR(xpbd::tet_six_volume(x[0], x[1], x[2], x[3]), 6.0 * v0, 1e-9);
    EXPECT_LT((x[3] - expect).norm(), 1e-12);
  }
}

TEST(MaterialSteps, ComplianceScalesTheLinearCorrectionExactly) {
  // Linear case: C_after = C_before · α̃ / (w|∇C|² + α̃), exactly, and larger α gives a smaller step.
  auto g = test::rng(22);
  const auto x_init = random_tet(g);
  const std::array<double, 4> w{0.0, 0.0, 0.0, 1.5};
  std::array<Vec3, 4> grad;
  const double v0 = 0.3;
  const double c0 = xpbd::tet_volume_constraint(x_init, v0, grad);
  double previous_step = std::numeric_limits<double>::infinity();
  for (double alpha_tilde : {0.0, 1e-3, 1e-2, 1e-1, 1.0, 10.0}) {
    auto x = x_init;
    double lambda = 0.0;
    xpbd::solve_tet_volume(ptrs<4>(x), w, v0, alpha_tilde, lambda);
    std::array<Vec3, 4> unused;
    const double c1 = xpbd::tet_volume_constraint(x, v0, unused);
    const double expect = c0 * alpha_tilde / (w[3] * grad[3].squaredNorm() + alpha_tilde);
    EXPECT_NEAR(c1, expect, 1e-12 * (1.0 + std::abs(c0)));
    EXPECT_NEAR(lambda, -c0 / (w[3] * grad[3].squaredNorm() + alpha_tilde), 1e-12);
    const double step = (x[3] - x_init[3]).norm();
    EXPECT_LT(step, previous_step);
    previous_step = step;
  }
}

TEST(MaterialSteps, DistanceTwoPointIsExactInOneStep) {
  auto g = test::rng(23);
  for (int trial = 0; trial < 20; ++trial) {
    Vec3 a = random_vec(g), b = random_vec(g);
    double lambda = 0.0;
    xpbd::solve_distance(a, b, 1.0, 3.0, 0.7, 0.0, lambda);
    EXPECT_NEAR((a - b).norm(), 0.7, 1e-12);
  }
}

/// The first-order step x_i += w_i ∇_i C Δλ with the finite-difference gradient, for comparison.
template <int N>
std::array<Vec3, N> reference_step(const std::array<Vec3, N>& x, const std::array<double, N>& w, double c,
                                   const std::function<double(const std::array<Vec3, N>&)>& f, double alpha_tilde) {
  const auto gr = fd_gradient<N>(x, f);
  double denom = alpha_tilde;
  for (int k = 0; k < N; ++k) denom += w[k] * gr[k].squaredNorm();
  auto out = x;
  for (int k = 0; k < N; ++k) out[k] += w[k] * (-c / denom) * gr[k];
  return out;
}

TEST(MaterialSteps, BendingStepMatchesReferenceAndConverges) {
  auto g = test::rng(24);
  const std::array<double, 4> w{1.0, 0.5, 2.0, 1.0};
  for (int trial = 0; trial < 20; ++trial) {
    auto x = random_hinge(g);
    const double theta0 = 0.3;
    auto f = [](const std::array<Vec3, 4>& p) { return xpbd::dihedral_angle(p[0], p[1], p[2], p[3]); };
    const auto expect = reference_step<4>(x, w, f(x) - theta0, f, 0.05);
    double lambda = 0.0;
    auto y = x;
    xpbd::solve_dihedral_bending(ptrs<4>(y), w, theta0, 0.05, lambda);
    EXPECT_LT(max_abs_diff<4>(y, expect), 1e-7);
    // Zero compliance: repeated projections (Newton on one scalar constraint) reach C = 0.
    for (int it = 0; it < 30; ++it) {
      double l = 0.0;
      xpbd::solve_dihedral_bending(ptrs<4>(x), w, theta0, 0.0, l);
    }
    EXPECT_NEAR(f(x), theta0, 1e-9);
  }
}

TEST(MaterialSteps, StrandBendingStepMatchesReferenceAndConverges) {
  auto g = test::rng(25);
  const std::array<double, 3> w{1.0, 2.0, 0.5};
  for (int trial = 0; trial < 20; ++trial) {
    std::array<Vec3, 3> x{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1.7, 0.7, 0)};
    for (auto& v : x) v += random_vec(g, 0.2);
    const double phi0 = 0.2;
    auto f = [](const std::array<Vec3, 3>& p) { return xpbd::turning_angle(p[0], p[1], p[2]); };
    const auto expect = reference_step<3>(x, w, f(x) - phi0, f, 0.05);
    double lambda = 0.0;
    auto y = x;
    xpbd::solve_strand_bending(ptrs<3>(y), w, phi0, 0.05, lambda);
    EXPECT_LT(max_abs_diff<3>(y, expect), 1e-7);
    for (int it = 0; it < 30; ++it) {
      double l = 0.0;
      xpbd::solve_strand_bending(ptrs<3>(x), w, phi0, 0.0, l);
    }
    EXPECT_NEAR(f(x), phi0, 1e-9);
  }
}

TEST(MaterialSteps, LargerComplianceGivesSmallerBendingCorrection) {
  auto g = test::rng(26);
  const auto x0 = random_hinge(g);
  double previous = std::numeric_limits<double>::infinity();
  for (double alpha_tilde : {0.0, 0.01, 0.1, 1.0, 10.0}) {
    auto x = x0;
    double lambda = 0.0;
    xpbd::solve_dihedral_bending(ptrs<4>(x), {1, 1, 1, 1}, 0.0, alpha_tilde, lambda);
    const double moved = max_abs_diff<4>(x, x0);
    EXPECT_LT(moved, previous);
    previous = moved;
  }
}

TEST(MaterialSteps, TetConstraintsConvergeFromADeformedTet) {
  auto g = test::rng(27);
  const auto rest = random_tet(g);
  const Mat3 dm_inv = rest_inverse_of(rest);
  const double v0 = xpbd::tet_six_volume(rest[0], rest[1], rest[2], rest[3]) / 6.0;
  auto x = rest;
  for (auto& v : x) v += random_vec(g, 0.15);
  for (int it = 0; it < 200; ++it) {
    double l1 = 0.0, l2 = 0.0;
    xpbd::solve_tet_deviatoric(ptrs<4>(x), {1, 1, 1, 1}, dm_inv, 0.0, l1);
    xpbd::solve_tet_volume(ptrs<4>(x), {1, 1, 1, 1}, v0, 0.0, l2);
  }
  // Both constraints at zero means F is a rotation: the tet is congruent to its rest shape.
  for (int a = 0; a < 4; ++a)
    for (int b = a + 1; b < 4; ++b) EXPECT_NEAR((x[a] - x[b]).norm(), (rest[a] - rest[b]).norm(), 1e-6);
}

// ---------------------------------------------------------------------------------------------
// Invariance under rigid motions of the rest state

TEST(MaterialInvariance, RigidMotionsGiveZeroConstraintAndZeroCorrection) {
  auto g = test::rng(31);
  for (int trial = 0; trial < 20; ++trial) {
    const Mat3 r = random_rotation(g);
    const Vec3 t = random_vec(g, 5.0);
    auto move = [&](const Vec3& p) { return Vec3(r * p + t); };

    const auto hinge = random_hinge(g);
    const double theta0 = xpbd::dihedral_angle(hinge[0], hinge[1], hinge[2], hinge[3]);
    std::array<Vec3, 4> xh{move(hinge[0]), move(hinge[1]), move(hinge[2]), move(hinge[3])};
    const auto xh0 = xh;
    double l = 0.0;
    xpbd::solve_dihedral_bending(ptrs<4>(xh), {1, 1, 1, 1}, theta0, 0.0, l);
    EXPECT_LT(max_abs_diff<4>(xh, xh0), 1e-12);

    std::array<Vec3, 3> strand{Vec3(0, 0, 0), Vec3(1, 0.1, 0), Vec3(1.5, 0.9, 0.2)};
    const double phi0 = xpbd::turning_angle(strand[0], strand[1], strand[2]);
    std::array<Vec3, 3> xs{move(strand[0]), move(strand[1]), move(strand[2])};
    const auto xs0 = xs;
    l = 0.0;
    xpbd::solve_strand_bending(ptrs<3>(xs), {1, 1, 1}, phi0, 0.0, l);
    EXPECT_LT(max_abs_diff<3>(xs, xs0), 1e-12);

    const auto tet = random_tet(g);
    const double v0 = xpbd::tet_six_volume(tet[0], tet[1], tet[2], tet[3]) / 6.0;
    const Mat3 dm_inv = rest_inverse_of(tet);
    std::array<Vec3, 4> xt{move(tet[0]), move(tet[1]), move(tet[2]), move(tet[3])};
    const auto xt0 = xt;
    // C_D is zero up to round-off: either reported as satisfied (false) or as a round-off value.
    double c = 0.0;
    std::array<Vec3, 4> grad;
    if (xpbd::tet_deviatoric_constraint(xt, dm_inv, c, grad)) {
      EXPECT_NEAR(c, 0.0, 1e-12);
    }
    EXPECT_NEAR(xpbd::tet_volume_constraint(xt, v0, grad), 0.0, 1e-12);
    double l1 = 0.0, l2 = 0.0;
    xpbd::solve_tet_deviatoric(ptrs<4>(xt), {1, 1, 1, 1}, dm_inv, 0.0, l1);
    xpbd::solve_tet_volume(ptrs<4>(xt), {1, 1, 1, 1}, v0, 0.0, l2);
    EXPECT_LT(max_abs_diff<4>(xt, xt0), 1e-12);
  }
}

// ---------------------------------------------------------------------------------------------
// Degenerate input

TEST(MaterialDegenerate, ZeroAreaTrianglesAreSkipped) {
  // Wing on the edge line, wing on an edge end point, zero-length edge: no update, no NaN.
  const std::vector<std::array<Vec3, 4>> cases{
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5, 0, 0), Vec3(0.5, -1, 0)},
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5, 1, 0), Vec3(1, 0, 0)},
      {Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(0.5, 1, 0), Vec3(0.5, -1, 0.2)},
      {Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(0, 0, 0)},
  };
  for (const auto& c : cases) {
    auto x = c;
    double lambda = 0.0;
    std::array<Vec3, 4> grad;
    double theta = 0.0;
    EXPECT_FALSE(xpbd::dihedral_angle_gradient(x[0], x[1], x[2], x[3], theta, grad));
    EXPECT_TRUE(std::isfinite(xpbd::dihedral_angle(x[0], x[1], x[2], x[3])));
    xpbd::solve_dihedral_bending(ptrs<4>(x), {1, 1, 1, 1}, 0.5, 0.0, lambda);
    EXPECT_TRUE(all_finite<4>(x));
    EXPECT_EQ(lambda, 0.0);
  }
}

TEST(MaterialDegenerate, CollinearAndCoincidentStrandPoints) {
  const std::vector<std::array<Vec3, 3>> cases{
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0)},  // straight
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 0, 0)},  // folded back
      {Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(1, 1, 0)},  // zero-length segment
      {Vec3(1, 1, 1), Vec3(1, 1, 1), Vec3(1, 1, 1)},  // all coincident
  };
  for (const auto& c : cases) {
    auto x = c;
    double lambda = 0.0;
    EXPECT_TRUE(std::isfinite(xpbd::turning_angle(x[0], x[1], x[2])));
    xpbd::solve_strand_bending(ptrs<3>(x), {1, 1, 1}, 0.4, 0.0, lambda);
    EXPECT_TRUE(all_finite<3>(x));
  }
}

TEST(MaterialDegenerate, InvertedAndFlatTetsStayFinite) {
  const std::array<Vec3, 4> rest{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  const Mat3 dm_inv = rest_inverse_of(rest);
  const double v0 = 1.0 / 6.0;
  const std::vector<std::array<Vec3, 4>> cases{
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, -1)},     // inverted
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0.3, 0.3, 0)},  // flat
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0), Vec3(3, 0, 0)},      // collinear
      {Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(0, 0, 0)},      // collapsed to a point
  };
  for (const auto& c : cases) {
    auto x = c;
    double l1 = 0.0, l2 = 0.0;
    for (int it = 0; it < 5; ++it) {
      xpbd::solve_tet_deviatoric(ptrs<4>(x), {1, 1, 1, 1}, dm_inv, 0.0, l1);
      xpbd::solve_tet_volume(ptrs<4>(x), {1, 1, 1, 1}, v0, 0.0, l2);
    }
    EXPECT_TRUE(all_finite<4>(x));
  }
  // The volume term alone restores an inverted tet with one dynamic vertex in a single step.
  auto x = cases[0];
  double l = 0.0;
  xpbd::solve_tet_volume(ptrs<4>(x), {0, 0, 0, 1}, v0, 0.0, l);
  EXPECT_NEAR(xpbd::tet_six_volume(x[0], x[1], x[2], x[3]), 1.0, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Shape matching

std::vector<Vec3> random_body(std::mt19937_64& g, int n) {
  std::vector<Vec3> p;
  for (int i = 0; i < n; ++i) p.push_back(random_vec(g, 1.0));
  return p;
}

TEST(ShapeMatching, RecoversARotatedAndTranslatedBodyExactly) {
  auto g = test::rng(41);
  for (int trial = 0; trial < 20; ++trial) {
    const auto rest = random_body(g, 12);
    std::uniform_real_distribution<double> um(0.5, 3.0);
    std::vector<double> m(rest.size()), w(rest.size());
    Vec3 c0 = Vec3::Zero();
    double total = 0.0;
    for (size_t i = 0; i < rest.size(); ++i) {
      m[i] = um(g), w[i] = 1.0 / m[i];
      c0 += m[i] * rest[i], total += m[i];
    }
    c0 /= total;
    std::vector<Vec3> q;
    for (const auto& p : rest) q.push_back(p - c0);
    const Mat3 r = random_rotation(g);
    const Vec3 t = random_vec(g, 10.0);
    std::vector<Vec3> x;
    for (const auto& p : rest) x.push_back(r * p + t);
    const auto moved = x;
    xpbd::solve_shape_matching(x, w, q, m);
    for (size_t i = 0; i < x.size(); ++i) EXPECT_LT((x[i] - moved[i]).norm(), 1e-12);

    // A deformed body becomes rigid again: congruent to the rest shape, mass-weighted centre kept.
    std::vector<Vec3> y;
    Vec3 cy = Vec3::Zero();
    for (const auto& p : moved) {
      y.push_back(p + random_vec(g, 0.1));
      cy += m[y.size() - 1] * y.back();
    }
    cy /= total;
    xpbd::solve_shape_matching(y, w, q, m);
    Vec3 cz = Vec3::Zero();
    for (size_t i = 0; i < y.size(); ++i) cz += m[i] * y[i];
    EXPECT_LT((cz / total - cy).norm(), 1e-12);
    for (size_t i = 0; i < y.size(); ++i)
      for (size_t j = i + 1; j < y.size(); ++j) EXPECT_NEAR((y[i] - y[j]).norm(), (rest[i] - rest[j]).norm(), 1e-12);
  }
}

TEST(ShapeMatching, PolarRotationIsAProperRotation) {
  auto g = test::rng(42);
  for (int trial = 0; trial < 50; ++trial) {
    Mat3 a = Mat3::Random();
    if (trial % 3 == 0) a.col(2) = a.col(0) * 0.5;  // rank deficient
    if (trial % 5 == 0) a = -a;                     // reflection part
    const Mat3 r = xpbd::polar_rotation(a);
    EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
    EXPECT_LT((r.transpose() * r - Mat3::Identity()).norm(), 1e-12);
  }
  const Mat3 rot = random_rotation(g);
  EXPECT_LT((xpbd::polar_rotation(rot * Eigen::Vector3d(1, 2, 3).asDiagonal()) - rot).norm(), 1e-12);
}

// The Newton polar iteration (issue 13: it replaces the SVD in the tet sweeps) against the SVD:
// the same rotation within 1e-12 for stretched, sheared and compressed F, and the SVD's answer for
// inverted, rank-deficient, zero and NaN input (the fallback).
TEST(PolarRotation, NewtonMatchesSvd) {
  auto g = test::rng(7);
  for (int trial = 0; trial < 400; ++trial) {
    Mat3 a = random_rotation(g) * (Mat3::Identity() + (trial % 4 == 0 ? 0.9 : 0.3) * Mat3::Random());
    if (trial % 7 == 0) a.col(2) = a.col(0) * 0.5 + a.col(1) * 0.25;                              // rank 2 (flat tet)
    if (trial % 5 == 0) a.col(1) = -a.col(1);                                                     // inverted
    if (trial % 11 == 0) a = Mat3::Zero();                                                        // fully degenerate
    if (trial % 13 == 0) a = random_rotation(g) * Eigen::Vector3d(1.0, 1e-3, 1e-3).asDiagonal();  // squashed
    const Mat3 svd = xpbd::polar_rotation(a);
    const Mat3 r = xpbd::polar_rotation_newton(a);
    EXPECT_LT((r - svd).norm(), 1e-12) << "trial " << trial << "\n" << a;
    EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
  }
  Mat3 nan = Mat3::Identity();
  nan(1, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(xpbd::polar_rotation_newton(nan).allFinite(), xpbd::polar_rotation(nan).allFinite());
  const Mat3 rot = random_rotation(g);
  EXPECT_LT((xpbd::polar_rotation_newton(rot * Eigen::Vector3d(1, 2, 3).asDiagonal()) - rot).norm(), 1e-12);
}

// The Newton iteration stops after a step below 1e-7 without a confirming step (its error is then
// about step²/2): on the F of a mildly strained tet (the sweeps' common case) it must still agree
// with the SVD to round-off, not merely to 1e-12.
TEST(PolarRotation, NewtonStopsAtRoundOffForMildStrain) {
  auto g = test::rng(11);
  std::uniform_real_distribution<double> size(0.0, 1.0);
  for (int trial = 0; trial < 2000; ++trial) {
    Mat3 e = Mat3::Random();
    e = 0.5 * (e + e.transpose());
    e *= (trial % 3 == 0 ? 1e-6 : trial % 3 == 1 ? 0.02 : 0.3) * size(g) / std::max(e.norm(), 1e-300);
    const Mat3 a = random_rotation(g) * (Mat3::Identity() + e);
    EXPECT_LT((xpbd::polar_rotation_newton(a) - xpbd::polar_rotation(a)).norm(), 2e-14) << "trial " << trial << "\n"
                                                                                        << a;
  }
}

TEST(ShapeMatching, FlatAndReflectedInputStaysFinite) {
  // A planar body mirrored through its plane must come back as a rotation, not a reflection.
  const std::vector<Vec3> q{Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(-1, 0, 0), Vec3(0, -1, 0)};
  const std::vector<double> m(4, 1.0), w(4, 1.0);
  std::vector<Vec3> x{Vec3(1, 0, 0), Vec3(0, -1, 0), Vec3(-1, 0, 0), Vec3(0, 1, 0)};
  xpbd::solve_shape_matching(x, w, q, m);
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_TRUE(x[i].allFinite());
    EXPECT_NEAR(x[i].norm(), 1.0, 1e-12);
  }
  std::vector<Vec3> same(4, Vec3(2, 2, 2));
  xpbd::solve_shape_matching(same, w, q, m);
  for (const auto& p : same) EXPECT_TRUE(p.allFinite());
}

// ---------------------------------------------------------------------------------------------
// MaterialSystem on a mixed scene

struct MixedScene {
  Topology topo;
  SimState state;
  SimulationParams params;
};

/// An n-by-n-vertex cloth with its first corner pinned, a 6-vertex curly strand, a 2x2x2-cell tet
/// block (5 tets per cell), a rigid cube surface, a particle and an obstacle; masses in [0.5, 2].
MixedScene make_mixed_scene(int n = 4) {
  MixedScene s;
  TopologyBuilder b;
  std::vector<Vec3> pos;
  // Cloth.
  std::vector<Vec3i> cloth_faces;
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const Index v = j * n + i;
      cloth_faces.emplace_back(v, v + 1, v + n + 1);
      cloth_faces.emplace_back(v, v + n + 1, v + n);
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) pos.emplace_back(0.4 * i / (n - 1), 0.02 * std::sin(i + j), 0.4 * j / (n - 1));
  b.add_object("cloth", ObjectKind::cloth, n * n, cloth_faces);
  // Strand (a helix).
  std::vector<Index> line;
  for (int k = 0; k < 6; ++k) {
    line.push_back(k);
    pos.emplace_back(1.0 + 0.1 * std::cos(k), 0.05 * k, 0.1 * std::sin(k));
  }
  b.add_object("hair", ObjectKind::strand, 6, {}, {}, {line});
  // Tet block: 3x3x3 grid vertices, 5 tets per cell with alternating orientation.
  const int m = 3;
  auto gid = [&](int i, int j, int k) { return static_cast<Index>((k * m + j) * m + i); };
  std::vector<Vec4i> tets;
  for (int k = 0; k + 1 < m; ++k)
    for (int j = 0; j + 1 < m; ++j)
      for (int i = 0; i + 1 < m; ++i) {
        Index c[8];
        for (int a = 0; a < 8; ++a) c[a] = gid(i + (a & 1), j + ((a >> 1) & 1), k + ((a >> 2) & 1));
        const bool flip = (i + j + k) % 2 == 1;
        const std::array<std::array<int, 4>, 5> even{
            {{0, 1, 2, 4}, {1, 3, 2, 7}, {1, 4, 5, 7}, {2, 7, 6, 4}, {1, 2, 4, 7}}};
        const std::array<std::array<int, 4>, 5> odd{
            {{0, 1, 3, 5}, {0, 3, 2, 6}, {0, 5, 4, 6}, {3, 5, 7, 6}, {0, 3, 5, 6}}};
        for (const auto& t : flip ? odd : even) tets.emplace_back(c[t[0]], c[t[1]], c[t[2]], c[t[3]]);
      }
  std::vector<Vec3> block;
  for (int k = 0; k < m; ++k)
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < m; ++i) block.emplace_back(2.0 + 0.1 * i, 0.1 * j, 0.1 * k);
  // Orient every tet positively (the builder expects positive orientation).
  for (auto& t : tets)
    if (xpbd::tet_six_volume(block[t[0]], block[t[1]], block[t[2]], block[t[3]]) < 0.0) std::swap(t[2], t[3]);
  pos.insert(pos.end(), block.begin(), block.end());
  b.add_object("block", ObjectKind::tet_solid, m * m * m, {}, tets);
  // Rigid cube surface.
  const std::vector<Vec3i> cube_faces{{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                                      {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (int a = 0; a < 8; ++a) pos.emplace_back(3.0 + 0.2 * (a & 1), 0.2 * ((a >> 1) & 1), 0.2 * ((a >> 2) & 1));
  b.add_object("ball", ObjectKind::rigid, 8, cube_faces);
  // A particle cloud and an obstacle triangle get no constraints.
  pos.emplace_back(5, 0, 0);
  b.add_object("dust", ObjectKind::particles, 1);
  pos.emplace_back(6, 0, 0), pos.emplace_back(7, 0, 0), pos.emplace_back(6, 1, 0);
  b.add_object("floor", ObjectKind::obstacle, 3, {Vec3i(0, 1, 2)});
  s.topo = b.finish();

  s.state.resize(static_cast<Index>(pos.size()));
  auto g = test::rng(51);
  std::uniform_real_distribution<double> um(0.5, 2.0);
  for (size_t i = 0; i < pos.size(); ++i) {
    s.state.rest[i] = s.state.x[i] = pos[i];
    s.state.mass[i] = um(g);
    s.state.inv_mass[i] = 1.0 / s.state.mass[i];
  }
  s.state.inv_mass[0] = 0.0;  // pinned cloth corner
  for (Index v = s.topo.objects[5].vertex_begin; v < s.topo.objects[5].vertex_end; ++v) s.state.inv_mass[v] = 0.0;
  s.params.objects.resize(s.topo.objects.size());
  for (auto& o : s.params.objects) {
    set_material_key(o.material, "stretch_compliance", 1e-6);
    set_material_key(o.material, "bend_compliance", 1e-3);
    set_material_key(o.material, "volume_compliance", 1e-7);
    set_material_key(o.material, "shear_compliance", 1e-6);
  }
  return s;
}

TEST(MaterialSystem, CountsFollowObjectKinds) {
  const auto s = make_mixed_scene();
  const MaterialSystem ms(s.topo, s.state, s.params);
  const auto c = ms.counts();
  // Cloth 4x4: 3*3*3 + 3 + 3 = 33 edges, of which 9 diagonals + 2*(2*3) inner grid edges are interior.
  const Index cloth_edges = 33, strand_segments = 5;
  EXPECT_EQ(c.distance, cloth_edges + strand_segments);  // no tet edges, no rigid edges
  EXPECT_EQ(c.bending, 9 + 12);
  EXPECT_EQ(c.strand_bending, 4);
  EXPECT_EQ(c.tet_volume, 40);
  EXPECT_EQ(c.tet_deviatoric, 40);
  EXPECT_EQ(c.rigid_bodies, 1);
  EXPECT_GT(c.colours, 0);
}

/// No two constraints of one colour share a dynamic vertex (brute force over pairs).
template <int N>
void expect_valid_colouring(const std::vector<Eigen::Matrix<Index, N, 1>>& ids, const Colouring& col,
                            std::span<const double> w) {
  ASSERT_EQ(static_cast<size_t>(col.row_start.back()), ids.size());
  std::set<Index> seen(col.order.begin(), col.order.end());
  EXPECT_EQ(seen.size(), ids.size());
  for (Index k = 0; k < col.colours(); ++k)
    for (Index a = col.row_start[k]; a < col.row_start[k + 1]; ++a)
      for (Index b = a + 1; b < col.row_start[k + 1]; ++b)
        for (int i = 0; i < N; ++i)
          for (int j = 0; j < N; ++j) {
            const Index va = ids[col.order[a]][i], vb = ids[col.order[b]][j];
            EXPECT_FALSE(va == vb && w[va] > 0.0) << "colour " << k << " shares vertex " << va;
          }
}

TEST(MaterialSystem, ColouringSeparatesDynamicVertices) {
  const auto s = make_mixed_scene();
  const MaterialSystem ms(s.topo, s.state, s.params);
  expect_valid_colouring<2>(batch_of<DistanceBatch>(ms, "stretch").ids,
                            batch_of<DistanceBatch>(ms, "stretch").colouring, s.state.inv_mass);
  expect_valid_colouring<4>(batch_of<BendingBatch>(ms, "dihedral_bending").ids,
                            batch_of<BendingBatch>(ms, "dihedral_bending").colouring, s.state.inv_mass);
  expect_valid_colouring<3>(batch_of<StrandBendingBatch>(ms, "strand_bending").ids,
                            batch_of<StrandBendingBatch>(ms, "strand_bending").colouring, s.state.inv_mass);
  expect_valid_colouring<4>(batch_of<TetBatch>(ms, "tet_elasticity").ids,
                            batch_of<TetBatch>(ms, "tet_elasticity").colouring, s.state.inv_mass);
}

TEST(MaterialSystem, RestStateIsAnEquilibrium) {
  auto s = make_mixed_scene();
  MaterialSystem ms(s.topo, s.state, s.params);
  auto x = s.state.rest;
  ms.reset_multipliers();
  for (int sweep = 0; sweep < 3; ++sweep) ms.solve(x, s.state.inv_mass, 1e-3);
  for (size_t i = 0; i < x.size(); ++i) EXPECT_LT((x[i] - s.state.rest[i]).norm(), 1e-12) << "vertex " << i;
}

Positions perturbed(const MixedScene& s, std::uint64_t seed) {
  auto g = test::rng(seed);
  Positions x = s.state.rest;
  for (size_t i = 0; i < x.size(); ++i)
    if (s.state.inv_mass[i] > 0.0) x[i] += random_vec(g, 0.02);
  return x;
}

TEST(MaterialSystem, DeterministicAcrossThreadCounts) {
  // A 60x60 cloth makes colours of several hundred constraints, so the 2-thread run really splits them.
  const auto s = make_mixed_scene(60);
  std::vector<Positions> results;
  for (int threads : {1, 2}) {
    set_thread_count(threads);
    MaterialSystem ms(s.topo, s.state, s.params);
    auto x = perturbed(s, 52);
    ms.reset_multipliers();
    for (int sweep = 0; sweep < 5; ++sweep) ms.solve(x, s.state.inv_mass, 1e-3);
    results.push_back(x);
  }
  set_thread_count(0);
  ASSERT_EQ(results[0].size(), results[1].size());
  for (size_t i = 0; i < results[0].size(); ++i) EXPECT_EQ(results[0][i], results[1][i]) << "vertex " << i;
}

/// The substep loop runs the material sweeps once per substep and lets every later outer
/// iteration start from their result (Simulation::substep). That is exact only while the sweeps
/// after reset_multipliers() are a function of the positions, masses and dt alone: this test runs
/// them from one prediction, then from unrelated positions (which would leave any carried state,
/// such as a warm-started rotation, changed), then from the prediction again, and wants the same
/// bits. The mixed scene has cloth, a strand, a tet block and a rigid body.
TEST(MaterialSystem, SweepsFromAPredictionCarryNoStateBetweenCalls) {
  const auto s = make_mixed_scene(20);
  MaterialSystem ms(s.topo, s.state, s.params);
  EXPECT_GT(ms.counts().tet_deviatoric, 0);
  EXPECT_GT(ms.counts().rigid_bodies, 0);
  const Positions prediction = perturbed(s, 77), other = perturbed(s, 78);
  auto sweeps = [&](Positions x) {
    ms.reset_multipliers();
    for (int sweep = 0; sweep < 4; ++sweep) ms.solve(x, s.state.inv_mass, 2e-3);
    return x;
  };
  const Positions first = sweeps(prediction);
  const Positions unrelated = sweeps(other);
  const Positions again = sweeps(prediction);
  ASSERT_NE(first, prediction) << "the sweeps must move something for the comparison to mean anything";
  ASSERT_NE(unrelated, first);
  for (size_t i = 0; i < first.size(); ++i) ASSERT_EQ(first[i], again[i]) << "vertex " << i;
}

/// The island schedule of MaterialSystem::solve (small islands as serial tasks, large ones colour by
/// colour) against the reference colour-by-colour sweep: positions and multipliers bit for bit, at 1
/// and 2 threads. n = 4 makes every island small (cloth, strand, tet block); n = 60 makes the cloth
/// large (colours of hundreds of constraints) next to the small strand and block.
TEST(MaterialSystem, IslandScheduleIsBitIdenticalToColourByColour) {
  for (int n : {4, 60}) {
    const auto s = make_mixed_scene(n);
    for (int threads : {1, 2}) {
      set_thread_count(threads);
      MaterialSystem islands(s.topo, s.state, s.params), colours(s.topo, s.state, s.params);
      const auto c = islands.counts();
      EXPECT_EQ(c.small_islands, n == 4 ? 3 : 2) << "n " << n;
      EXPECT_EQ(c.large_islands, n == 4 ? 0 : 1) << "n " << n;
      auto xa = perturbed(s, 54), xb = xa;
      islands.reset_multipliers(), colours.reset_multipliers();
      for (int sweep = 0; sweep < 5; ++sweep) {
        islands.solve(xa, s.state.inv_mass, 1e-3);
        colours.solve_by_colour(xb, s.state.inv_mass, 1e-3);
      }
      for (size_t i = 0; i < xa.size(); ++i)
        ASSERT_EQ(xa[i], xb[i]) << "vertex " << i << ", n " << n << ", " << threads << " threads";
      EXPECT_EQ(batch_of<DistanceBatch>(islands, "stretch").lambda, batch_of<DistanceBatch>(colours, "stretch").lambda);
      EXPECT_EQ(batch_of<BendingBatch>(islands, "dihedral_bending").lambda,
                batch_of<BendingBatch>(colours, "dihedral_bending").lambda);
      EXPECT_EQ(batch_of<StrandBendingBatch>(islands, "strand_bending").lambda,
                batch_of<StrandBendingBatch>(colours, "strand_bending").lambda);
      EXPECT_EQ(batch_of<TetBatch>(islands, "tet_elasticity").lambda_volume,
                batch_of<TetBatch>(colours, "tet_elasticity").lambda_volume);
      EXPECT_EQ(batch_of<TetBatch>(islands, "tet_elasticity").lambda_deviatoric,
                batch_of<TetBatch>(colours, "tet_elasticity").lambda_deviatoric);
      // The sweeps did something: the comparison is not between two untouched copies.
      EXPECT_NE(xa, perturbed(s, 54));
    }
  }
  set_thread_count(0);
}

/// Several identical small bodies (one island each) at 1 and 2 threads: the island tasks really run
/// concurrently at 2 threads and give the same bits as one thread and as the colour-by-colour sweep.
TEST(MaterialSystem, ManySmallIslandsAreDeterministicAcrossThreadCounts) {
  // Eight copies of the mixed scene's tet block, side by side, each its own tet_solid object.
  const auto base = make_mixed_scene();
  const auto& block = base.topo.objects[2];
  ASSERT_EQ(block.kind, ObjectKind::tet_solid);
  TopologyBuilder b;
  std::vector<Vec3> pos;
  std::vector<Vec4i> tets;
  for (Index t = block.tet_begin; t < block.tet_end; ++t) {
    Vec4i v = base.topo.tets[t];
    for (int a = 0; a < 4; ++a) v[a] -= block.vertex_begin;
    tets.push_back(v);
  }
  const Index nb = block.num_vertices();
  for (int copy = 0; copy < 8; ++copy) {
    for (Index i = 0; i < nb; ++i) pos.push_back(base.state.rest[block.vertex_begin + i] + Vec3(0.5 * copy, 0, 0));
    b.add_object("block" + std::to_string(copy), ObjectKind::tet_solid, nb, {}, tets);
  }
  MixedScene s;
  s.topo = b.finish();
  s.state.resize(static_cast<Index>(pos.size()));
  for (size_t i = 0; i < pos.size(); ++i) {
    s.state.rest[i] = s.state.x[i] = pos[i];
    s.state.mass[i] = 1.0 + 0.01 * static_cast<double>(i % 7);
    s.state.inv_mass[i] = 1.0 / s.state.mass[i];
  }
  s.params.objects.resize(s.topo.objects.size());
  for (auto& o : s.params.objects) {
    set_material_key(o.material, "volume_compliance", 1e-7);
    set_material_key(o.material, "shear_compliance", 1e-6);
  }
  std::vector<Positions> results;
  for (int threads : {1, 2}) {
    set_thread_count(threads);
    MaterialSystem islands(s.topo, s.state, s.params), colours(s.topo, s.state, s.params);
    EXPECT_EQ(islands.counts().small_islands, 8);
    EXPECT_EQ(islands.counts().large_islands, 0);
    auto xa = perturbed(s, 55), xb = xa;
    islands.reset_multipliers(), colours.reset_multipliers();
    for (int sweep = 0; sweep < 8; ++sweep) {
      islands.solve(xa, s.state.inv_mass, 1e-3);
      colours.solve_by_colour(xb, s.state.inv_mass, 1e-3);
    }
    for (size_t i = 0; i < xa.size(); ++i) ASSERT_EQ(xa[i], xb[i]) << "vertex " << i << ", " << threads << " threads";
    results.push_back(xa);
  }
  set_thread_count(0);
  EXPECT_EQ(results[0], results[1]);
}

TEST(MaterialSystem, SweepsRestoreShapesAndKeepKinematicVertices) {
  const auto s = make_mixed_scene();
  MaterialSystem ms(s.topo, s.state, s.params);
  auto x = perturbed(s, 53);
  const auto x0 = x;
  ms.reset_multipliers();
  for (int sweep = 0; sweep < 60; ++sweep) ms.solve(x, s.state.inv_mass, 1e-2);
  for (size_t i = 0; i < x.size(); ++i) {
    ASSERT_TRUE(x[i].allFinite());
    if (s.state.inv_mass[i] == 0.0) {
      EXPECT_EQ(x[i], x0[i]);
    }
  }
  // The rigid cube is exactly congruent to its rest shape after the sweep.
  const auto& ball = s.topo.objects[3];
  for (Index i = ball.vertex_begin; i < ball.vertex_end; ++i)
    for (Index j = i + 1; j < ball.vertex_end; ++j)
      EXPECT_NEAR((x[i] - x[j]).norm(), (s.state.rest[i] - s.state.rest[j]).norm(), 1e-12);
  // The tet block recovers its volume (stiff moduli, many sweeps).
  double v = 0.0, v0 = 0.0;
  for (const auto& t : s.topo.tets) {
    v += xpbd::tet_six_volume(x[t[0]], x[t[1]], x[t[2]], x[t[3]]) / 6.0;
    v0 += xpbd::tet_six_volume(s.state.rest[t[0]], s.state.rest[t[1]], s.state.rest[t[2]], s.state.rest[t[3]]) / 6.0;
  }
  EXPECT_NEAR(v / v0, 1.0, 1e-3);
  // Strand bending brings the turning angles back toward the rest helix.
  const auto& sb = batch_of<StrandBendingBatch>(ms, "strand_bending");
  for (Index c = 0; c < sb.size(); ++c) {
    const Vec3i& id = sb.ids[c];
    EXPECT_NEAR(xpbd::turning_angle(x[id[0]], x[id[1]], x[id[2]]), sb.rest_angle[c], 0.05);
  }
}

TEST(MaterialSystem, PinnedRigidBodyFollowsItsPins) {
  // One kinematic vertex: the body keeps that vertex fixed and stays rigid.
  auto s = make_mixed_scene();
  const auto& ball = s.topo.objects[3];
  const Index pin = ball.vertex_begin;
  s.state.inv_mass[pin] = 0.0;
  MaterialSystem ms(s.topo, s.state, s.params);
  auto x = perturbed(s, 54);
  x[pin] += Vec3(0.05, 0.0, 0.0);  // the pin moved by its script
  ms.solve(x, s.state.inv_mass, 1e-2);
  for (Index i = ball.vertex_begin; i < ball.vertex_end; ++i)
    for (Index j = i + 1; j < ball.vertex_end; ++j)
      EXPECT_NEAR((x[i] - x[j]).norm(), (s.state.rest[i] - s.state.rest[j]).norm(), 1e-7);
}

/// Tip drop of a horizontal 11-vertex strand clamped at its first two vertices after 1 s under
/// gravity with a plain XPBD integrator and MaterialSystem (damped, so it settles).
double cantilever_tip_drop(double bend_compliance) {
  TopologyBuilder b;
  std::vector<Index> line;
  for (Index k = 0; k < 11; ++k) line.push_back(k);
  b.add_object("wire", ObjectKind::strand, 11, {}, {}, {line});
  const Topology topo = b.finish();
  SimState st;
  st.resize(11);
  for (Index k = 0; k < 11; ++k) st.rest[k] = st.x[k] = Vec3(0.02 * k, 0, 0);
  st.inv_mass.assign(11, 1.0 / 0.002);
  st.inv_mass[0] = st.inv_mass[1] = 0.0;
  SimulationParams p;
  p.objects.resize(1);
  set_material_key(p.objects[0].material, "bend_compliance", bend_compliance);
  MaterialSystem ms(topo, st, p);
  const double dt = 1.0 / 600.0;
  const Vec3 gravity(0, -9.81, 0);
  for (int step = 0; step < 600; ++step) {
    Positions x = st.x;
    for (Index k = 0; k < 11; ++k)
      if (st.inv_mass[k] > 0.0) x[k] += dt * st.v[k] + dt * dt * gravity;
    ms.reset_multipliers();
    for (int sweep = 0; sweep < 10; ++sweep) ms.solve(x, st.inv_mass, dt);
    for (Index k = 0; k < 11; ++k) {
      st.v[k] = 0.98 * (x[k] - st.x[k]) / dt;
      st.x[k] = x[k];
    }
  }
  for (const auto& v : st.x) EXPECT_TRUE(v.allFinite());
  // Inextensible segments stay at their rest length.
  for (Index k = 0; k < 10; ++k) EXPECT_NEAR((st.x[k + 1] - st.x[k]).norm(), 0.02, 1e-3);
  return -st.x[10].y();
}

TEST(MaterialSystem, CantileverDroopsMoreWithLargerBendCompliance) {
  double previous = -1.0;
  for (double alpha : {1e-4, 1e-2, 1.0, 100.0}) {
    const double drop = cantilever_tip_drop(alpha);
    EXPECT_GT(drop, previous) << "bend_compliance " << alpha;
    previous = drop;
  }
  EXPECT_LT(cantilever_tip_drop(1e-6), 0.01);  // stiff wire: nearly straight (sag of 10 sweeps only)
  EXPECT_GT(cantilever_tip_drop(1e4), 0.15);   // limp wire: hangs nearly straight down (length 0.2)
}

TEST(MaterialSystem, RejectsMismatchedParameters) {
  auto s = make_mixed_scene();
  s.params.objects.pop_back();
  EXPECT_THROW(MaterialSystem(s.topo, s.state, s.params), std::logic_error);
}

TEST(MaterialSystem, DegenerateRestTrianglesAreSkippedWithAWarning) {
  TopologyBuilder b;
  // Two triangles sharing edge (0,1); the second one has zero area in the rest state.
  b.add_object("sheet", ObjectKind::cloth, 4, {Vec3i(0, 1, 2), Vec3i(1, 0, 3)});
  const Topology topo = b.finish();
  SimState st;
  st.resize(4);
  st.rest = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0.5, 0, 0)};
  st.x = st.rest;
  st.inv_mass.assign(4, 1.0);
  SimulationParams p;
  p.objects.resize(1);
  test::ExpectWarnings expect;
  const MaterialSystem ms(topo, st, p);
  EXPECT_GT(test::counting_sink()->warnings.load(), 0);
  EXPECT_EQ(ms.counts().bending, 0);
  EXPECT_EQ(ms.counts().distance, 5);
}

}  // namespace
}  // namespace ccfr
