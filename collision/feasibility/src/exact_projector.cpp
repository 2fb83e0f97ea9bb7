#include "ccfr/feasibility/exact_projector.hpp"

#include <Eigen/Dense>
#include <array>
#include <limits>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

#include "ccfr/feasibility/plesnik.hpp"
#include "small_buffer.hpp"

namespace ccfr {

namespace {

/// Above this many planes, exact_region_projection uses the dual active-set method.
constexpr int kEnumerationLimit = 24;
/// A region with no feasible point within this many times the problem's size (max |d|, |q|) of
/// the anchor counts as empty (Farkas certificate in farkas_empty).
constexpr double kFarkasRadius = 1e8;

/// Checks the KKT certificate of a candidate point for active set `idx`: multipliers >= -tol,
/// the active planes hold with equality, every plane holds.
bool certified(const Vec3& p, std::span<const HalfSpace> planes, double margin, double tol, const int* idx,
               const double* lambda, int size) {
  for (int i = 0; i < size; ++i) {
    if (!(lambda[i] >= -tol)) return false;
    const HalfSpace& h = planes[static_cast<std::size_t>(idx[i])];
    if (!(std::abs(h.n.dot(p) + h.d - margin) <= tol)) return false;
  }
  for (const auto& h : planes)
    if (!(h.n.dot(p) + h.d - margin >= -tol)) return false;
  return true;
}

/// Hildreth's method: cyclic dual coordinate ascent on the multipliers. Converges to the
/// projection for a non-empty region; only used when no active set certifies.
///
/// It stops when the worst violation has shrunk to tol/1000, after kHildrethSweeps sweeps, or at a
/// stall: the least worst violation of a block of kHildrethBlock sweeps is within 0.1 % of the
/// previous block's (a block's best, since single sweeps are not monotone). On an empty region the
/// sweeps settle into a cycle whose worst violation repeats exactly, so a squeezed vertex pays two
/// blocks, not 20000 sweeps (no call on configs/ and configs/stress/ ever converged here: each one
/// was such a region). Safe either way: a point is returned only if every plane holds to -tol.
ExactProjection hildreth(const Vec3& q, std::span<const HalfSpace> planes, double margin, double tol) {
  constexpr int kHildrethSweeps = 20000, kHildrethBlock = 256;
  constexpr double kHildrethStall = 0.999;
  SmallBuffer<double> lambda(planes.size());
  std::fill(lambda.begin(), lambda.end(), 0.0);
  Vec3 p = q;
  // Per block: the largest (least violated) sweep's worst violation, <= 0; the previous block's.
  double block_best = -std::numeric_limits<double>::infinity(), last_best = block_best;
  for (int sweep = 0; sweep < kHildrethSweeps; ++sweep) {
    double worst = 0.0;
    for (std::size_t k = 0; k < planes.size(); ++k) {
      const HalfSpace& h = planes[k];
      const double nn = h.n.dot(h.n);
      if (!(nn > 0.0)) continue;
      const double r = h.n.dot(p) + h.d - margin;
      worst = std::min(worst, r);
      const double delta = std::max(-r / nn, -lambda[k]);
      lambda[k] += delta;
      p += delta * h.n;
    }
    if (worst >= -tol * 1e-3) break;
    block_best = std::max(block_best, worst);
    if ((sweep + 1) % kHildrethBlock == 0) {
      if (block_best <= kHildrethStall * last_best) break;
      last_best = block_best;
      block_best = -std::numeric_limits<double>::infinity();
    }
  }
  ExactProjection out;
  out.p = p;
  out.found = true;
  for (const auto& h : planes)
    if (!(h.n.dot(p) + h.d - margin >= -tol)) out.found = false;
  for (std::size_t k = 0; k < planes.size(); ++k) out.active += lambda[k] > 0.0 ? 1 : 0;
  return out;
}

/// Farkas certificate of an empty region: multipliers \f$\lambda \ge 0\f$ (1 on plane p, \f$-r_i\f$ on the
/// active planes) with \f$\mathbf{w} = \sum_k \lambda_k\mathbf{n}_k\f$ and \f$c = \sum_k\lambda_k(d_k - \text{margin})
/// < 0\f$. Summing the constraints gives \f$\mathbf{w}\cdot\mathbf{x} + c \ge 0\f$ for every feasible x, so none lies
/// within \f$\|\mathbf{x}\| < -c/\|\mathbf{w}\|\f$; the region counts as empty when that radius exceeds `radius`
/// (rounding leaves w ~ 1e-16, not 0, for truly inconsistent planes).
bool farkas_empty(std::span<const HalfSpace> planes, double margin, int p, const int* act, const double* r, int na,
                  double radius) {
  const HalfSpace& hp = planes[static_cast<std::size_t>(p)];
  Vec3 w = hp.n;
  double c = hp.d - margin;
  for (int i = 0; i < na; ++i) {
    const double lambda = std::max(0.0, -r[i]);
    const HalfSpace& h = planes[static_cast<std::size_t>(act[i])];
    w += lambda * h.n;
    c += lambda * (h.d - margin);
  }
  return c < 0.0 && -c > radius * w.norm();
}

/// Goldfarb–Idnani dual active-set method for
/// \f$\min_x \tfrac12\|x - q\|^2\f$ s.t. \f$\mathbf{n}_k^\top x + d_k - \text{margin} \ge 0\f$:
/// start at the unconstrained minimum q, add the most violated plane, take the largest primal/dual
/// step that keeps every multiplier non-negative, drop planes whose multiplier reaches zero.
/// Exact in exact arithmetic after finitely many steps; in 3-D at most three planes are active,
/// so every step solves a system of size <= 3. O(m) per step instead of the enumeration's
/// O(m^4), which matters for the hundreds of planes of a vertex in a dense cloth.
/// An empty region ends with active = -1 (Farkas certificate within `farkas_radius`) or -2 (unproven).
ExactProjection dual_active_set(const Vec3& q, std::span<const HalfSpace> planes, double margin, double tolerance,
                                double farkas_radius) {
  ExactProjection out;
  const int m = static_cast<int>(planes.size());
  Vec3 x = q;
  std::array<int, 3> act{};
  std::array<double, 3> u{};
  int na = 0;
  auto slack = [&](int k) {
    return planes[static_cast<std::size_t>(k)].n.dot(x) + planes[static_cast<std::size_t>(k)].d - margin;
  };
  for (int outer = 0; outer < 4 * m + 16; ++outer) {
    int p = -1;
    double worst = -tolerance;
    for (int k = 0; k < m; ++k) {
      const double nn = planes[static_cast<std::size_t>(k)].n.norm();
      if (!(nn > 0.0)) continue;
      const double sk = slack(k) / nn;
      if (sk < worst) worst = sk, p = k;
    }
    if (p < 0) {
      // A NaN slack fails every `<` above: only a finite point is certified feasible.
      if (!x.allFinite()) {
        out.active = -2;
        return out;
      }
      out.p = x;
      out.found = true;
      out.active = na;
      return out;
    }
    const Vec3& np = planes[static_cast<std::size_t>(p)].n;
    double up = 0.0;
    for (int inner = 0; inner <= 3; ++inner) {  // at most three drops before p can be added
      // z: n_p projected onto the null space of the active normals; r: their dual direction.
      Eigen::Matrix<double, 3, Eigen::Dynamic> N(3, na);
      for (int i = 0; i < na; ++i) N.col(i) = planes[static_cast<std::size_t>(act[i])].n;
      Eigen::VectorXd r = Eigen::VectorXd::Zero(na);
      Vec3 z = np;
      if (na > 0) {
        const Eigen::MatrixXd G = N.transpose() * N;
        r = G.ldlt().solve(N.transpose() * np);
        z = np - N * r;
      }
      double t1 = std::numeric_limits<double>::infinity();
      int drop = -1;
      for (int i = 0; i < na; ++i)
        if (r[i] > 1e-14 && u[i] / r[i] < t1) t1 = u[i] / r[i], drop = i;
      const double zz = z.squaredNorm();
      // With three independent active normals nothing is left of n_p in 3-D: a nonzero z there is
      // rounding of a nearly singular Gram matrix, and a primal step would add a fourth plane.
      const bool primal = na < 3 && zz > 1e-20 * np.squaredNorm();
      if (!primal && drop < 0) {
        // n_p = N r + z with z ~ 0 and r <= 0: the planes look inconsistent. Accept only what a
        // Farkas certificate proves (see farkas_empty); otherwise leave the verdict to the caller.
        out.active = farkas_empty(planes, margin, p, act.data(), r.data(), na, farkas_radius) ? -1 : -2;
        return out;
      }
      const double t2 = primal ? -slack(p) / zz : std::numeric_limits<double>::infinity();
      const double t = std::min(t1, t2);
      // A primal step beyond the emptiness radius comes from a nearly singular active set (z ~ 0):
      // rounding then decides its direction, and repeated steps grew x to infinity (a strand vertex
      // squeezed between a moving comb tooth and its neighbours). No verdict: the caller goes on.
      if (primal && t == t2 && !(t2 * std::sqrt(zz) <= farkas_radius)) {
        out.active = -2;
        return out;
      }
      if (primal) x += t * z;
      for (int i = 0; i < na; ++i) u[i] -= t * r[i];
      up += t;
      if (t2 <= t1) {
        act[na] = p;
        u[na] = up;
        ++na;
        break;
      }
      // Partial step: the multiplier of `drop` reached zero; remove it and retry the same plane.
      for (int i = drop; i + 1 < na; ++i) act[i] = act[i + 1], u[i] = u[i + 1];
      --na;
    }
    if (na > 3) return out;  // cannot happen with independent normals in 3-D; be safe
  }
  return out;
}

}  // namespace

ExactProjection exact_region_projection(const Vec3& q, std::span<const HalfSpace> planes, double margin,
                                        double tolerance) {
  ExactProjection out;
  const int m = static_cast<int>(planes.size());
  if (!q.allFinite()) return out;
  SmallBuffer<double> r(planes.size());
  SmallBuffer<unsigned char> viol(planes.size());
  bool any = false;
  for (int k = 0; k < m; ++k) {
    const HalfSpace& h = planes[static_cast<std::size_t>(k)];
    if (!h.n.allFinite() || !std::isfinite(h.d)) return out;
    r[k] = h.n.dot(q) + h.d - margin;
    viol[k] = r[k] < -tolerance;
    any = any || viol[k];
  }
  if (!any) {
    out.p = q;
    out.found = true;
    return out;
  }
  auto plane = [&](int k) -> const HalfSpace& { return planes[static_cast<std::size_t>(k)]; };

  // A region can only be empty when the anchor (p = 0) violates a plane. Points farther than
  // kFarkasRadius times the problem's size count as no feasible point at all.
  double size = q.norm(), anchor_slack = 0.0;
  for (const auto& h : planes) {
    size = std::max(size, std::abs(h.d - margin));
    anchor_slack = std::min(anchor_slack, h.d - margin);
  }
  const double farkas_radius = kFarkasRadius * size;

  // Many planes: the dual active-set method (the enumeration below is O(m^4)); its result is
  // certified by the same KKT-free feasibility check, and the enumeration remains the fallback.
  if (m > kEnumerationLimit) {
    ExactProjection e = dual_active_set(q, planes, margin, tolerance, farkas_radius);
    if (e.found) return e;
    if (e.active == -1) return ExactProjection{};  // proven empty: Hildreth would only burn its sweeps
    return hildreth(q, planes, margin, tolerance);
  }
  // Few planes, anchor outside: the region may be empty, and then no active set certifies and
  // Hildreth runs all its sweeps (5-6 ms). The dual active-set method proves emptiness in
  // microseconds; a region it does not prove empty goes on to the enumeration unchanged.
  if (anchor_slack < -tolerance && dual_active_set(q, planes, margin, tolerance, farkas_radius).active == -1)
    return ExactProjection{};

  // |S| = 1: lambda = -r / |n|^2 (positive exactly for violated planes).
  for (int i = 0; i < m; ++i) {
    if (!viol[i]) continue;
    const Vec3& n = plane(i).n;
    const double nn = n.dot(n);
    if (!(nn > 0.0)) continue;
    const double lambda = -r[i] / nn;
    const Vec3 p = q + lambda * n;
    if (certified(p, planes, margin, tolerance, &i, &lambda, 1)) {
      out = {p, true, 1};
      return out;
    }
  }
  // |S| = 2: G lambda = -r_S with the 2x2 Gram matrix G.
  for (int i = 0; i < m; ++i)
    for (int j = i + 1; j < m; ++j) {
      if (!viol[i] && !viol[j]) continue;
      const Vec3& ni = plane(i).n;
      const Vec3& nj = plane(j).n;
      const double g11 = ni.dot(ni), g22 = nj.dot(nj), g12 = ni.dot(nj);
      const double det = g11 * g22 - g12 * g12;
      if (!(det > 1e-15 * g11 * g22)) continue;  // parallel: the pair cannot be an active set
      const double l[2] = {(-r[i] * g22 + r[j] * g12) / det, (-r[j] * g11 + r[i] * g12) / det};
      const Vec3 p = q + l[0] * ni + l[1] * nj;
      const int idx[2] = {i, j};
      if (certified(p, planes, margin, tolerance, idx, l, 2)) {
        out = {p, true, 2};
        return out;
      }
    }
  // |S| = 3: the three planes meet in one point (Cramer's rule), multipliers from N^T lambda = p - q.
  for (int i = 0; i < m; ++i)
    for (int j = i + 1; j < m; ++j)
      for (int k = j + 1; k < m; ++k) {
        if (!viol[i] && !viol[j] && !viol[k]) continue;
        const Vec3& ni = plane(i).n;
        const Vec3& nj = plane(j).n;
        const Vec3& nk = plane(k).n;
        const Vec3 cjk = nj.cross(nk), cki = nk.cross(ni), cij = ni.cross(nj);
        const double det = ni.dot(cjk);
        if (!(std::abs(det) > 1e-12 * ni.norm() * nj.norm() * nk.norm())) continue;
        const double hi = margin - plane(i).d, hj = margin - plane(j).d, hk = margin - plane(k).d;
        const Vec3 p = (hi * cjk + hj * cki + hk * cij) / det;
        const Vec3 s = p - q;
        const double l[3] = {s.dot(cjk) / det, s.dot(cki) / det, s.dot(cij) / det};
        const int idx[3] = {i, j, k};
        if (certified(p, planes, margin, tolerance, idx, l, 3)) {
          out = {p, true, 3};
          return out;
        }
      }
  return hildreth(q, planes, margin, tolerance);
}

ExactProjector::ExactProjector(const ProjectorParams& params) : params_(params) { validate(params_); }

ProjectResult ExactProjector::project(const Vec3& x_anchor, const Vec3& x_candidate,
                                      std::span<const HalfSpace> planes) const {
  const double tol = params_.feasibility_tolerance;
  const ScreenedInput in = screen_input(x_anchor, x_candidate, planes, tol);
  if (!in.usable) return unusable_input(x_anchor);
  ProjectResult res;
  res.x = x_candidate;
  res.active = in.violated;
  const Vec3& q = in.q;
  const double d_min = in.d_min, scale = in.scale;
  if (res.active == 0) return res;

  // Certificate slack: the feasibility tolerance, or rounding relative to the problem's lengths.
  const double cert_tol = std::max(tol, 1e-13 * scale);
  ExactProjection e;
  if (d_min >= -tol) {
    e = exact_region_projection(q, planes, 0.0, cert_tol);
    if (e.found) e.p = retract_toward_anchor(e.p, params_.epsilon);
  } else {
    // Anchor outside (clarification 7): keep an inward margin of ε instead of retracting.
    if (params_.epsilon > 0.0) e = exact_region_projection(q, planes, params_.epsilon, cert_tol);
    if (!e.found) e = exact_region_projection(q, planes, 0.0, cert_tol);
  }
  res.iterations = e.active;
  if (!e.found) {
    res.status = ProjectStatus::infeasible;
    res.x = x_anchor;
    return res;
  }
  res.x = x_anchor + e.p;
  res.status = ProjectStatus::projected;
  return res;
}

}  // namespace ccfr
