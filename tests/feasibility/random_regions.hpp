#pragma once
// Seeded random regions and an independent brute-force reference projection for the feasibility tests.
#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "ccfr/feasibility/region.hpp"

namespace ccfr::test {

inline Vec3 random_unit(std::mt19937_64& g) {
  std::normal_distribution<double> nd(0.0, 1.0);
  Vec3 v;
  do v = Vec3(nd(g), nd(g), nd(g));
  while (v.norm() < 1e-3);
  return v.normalized();
}

/// A unit vector within `max_angle` of `axis`.
inline Vec3 random_in_cone(std::mt19937_64& g, const Vec3& axis, double max_angle) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double ct = 1.0 - u(g) * (1.0 - std::cos(max_angle));
  const double st = std::sqrt(std::max(0.0, 1.0 - ct * ct));
  const double ph = 2.0 * M_PI * u(g);
  const Vec3 a = axis.normalized();
  const Vec3 t = a.unitOrthogonal(), b = a.cross(t);
  return (ct * a + st * (std::cos(ph) * t + std::sin(ph) * b)).normalized();
}

/// One random projection problem: anchor, candidate, half-spaces with d >= 0 (anchor feasible).
struct RandomProblem {
  Vec3 anchor;
  Vec3 candidate;
  std::vector<HalfSpace> planes;
};

/// `count` half-spaces; even seeds draw normals on the whole sphere, odd seeds in a 60-degree cone
/// (the clustered normals of folded cloth). d in [0, r], candidate within 1.5 r of the anchor.
inline RandomProblem random_problem(std::mt19937_64& g, int count, double r = 0.01) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  RandomProblem p;
  p.anchor = Vec3(u(g), u(g), u(g));
  const bool clustered = u(g) < 0.5;
  const Vec3 axis = random_unit(g);
  for (int k = 0; k < count; ++k) {
    HalfSpace h;
    h.n = clustered ? random_in_cone(g, axis, M_PI / 3) : random_unit(g);
    h.d = r * u(g);
    p.planes.push_back(h);
  }
  p.candidate = p.anchor + 1.5 * r * std::cbrt(u(g)) * random_unit(g);
  return p;
}

/// Reference projection onto {p : n_k.p + d_k >= 0} (p relative to the anchor), independent of the
/// library: the projection of q onto the affine hull of every subset of at most three planes
/// (Eigen's complete orthogonal decomposition, so dependent subsets are fine), keeping the closest
/// candidate that satisfies every plane. The optimum is such a candidate, and every candidate is
/// feasible, so the closest one is the optimum. Returns false when no candidate is feasible.
inline bool reference_projection(const Vec3& q, const std::vector<HalfSpace>& planes, double tol, Vec3& best) {
  const int m = static_cast<int>(planes.size());
  double best_dist = std::numeric_limits<double>::infinity();
  auto feasible = [&](const Vec3& p) {
    for (const auto& h : planes)
      if (h.n.dot(p) + h.d < -tol) return false;
    return true;
  };
  auto consider = [&](const std::vector<int>& s) {
    Vec3 p = q;
    if (!s.empty()) {
      Eigen::MatrixXd a(static_cast<Eigen::Index>(s.size()), 3);
      Eigen::VectorXd b(static_cast<Eigen::Index>(s.size()));
      for (size_t i = 0; i < s.size(); ++i) {
        a.row(static_cast<Eigen::Index>(i)) = planes[static_cast<size_t>(s[i])].n.transpose();
        b(static_cast<Eigen::Index>(i)) = -planes[static_cast<size_t>(s[i])].d;
      }
      // Minimum-norm correction: p = q + A^+ (b - A q).
      const Eigen::VectorXd rhs = b - a * q;
      p = q + a.completeOrthogonalDecomposition().solve(rhs);
      if ((a * p - b).cwiseAbs().maxCoeff() > tol) return;  // inconsistent subset
    }
    if (!feasible(p)) return;
    const double dist = (p - q).norm();
    if (dist < best_dist) {
      best_dist = dist;
      best = p;
    }
  };
  consider({});
  for (int i = 0; i < m; ++i) {
    consider({i});
    for (int j = i + 1; j < m; ++j) {
      consider({i, j});
      for (int k = j + 1; k < m; ++k) consider({i, j, k});
    }
  }
  return std::isfinite(best_dist);
}

}  // namespace ccfr::test
