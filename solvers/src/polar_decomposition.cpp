// The rotation of the polar decomposition: SVD (any matrix, det R = +1) and Higham's scaled
// Newton iteration (well-conditioned matrices with det > 0, the tets' F).
#include "ccfr/solvers/polar_decomposition.hpp"

#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/SVD>

namespace ccfr::xpbd {

Eigen::Matrix3d polar_rotation(const Eigen::Matrix3d& a) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(a, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d& u = svd.matrixU();
  const Eigen::Matrix3d& v = svd.matrixV();
  // Flip the axis of the smallest singular value (last in Eigen's order) when U Vᵀ is a
  // reflection: the closest rotation, and the right answer for flat bodies (rank 2).
  Eigen::Vector3d d(1.0, 1.0, (u * v.transpose()).determinant() < 0.0 ? -1.0 : 1.0);
  return u * d.asDiagonal() * v.transpose();
}

namespace {

constexpr int kMaxIterations = 16;  // never reached for det A > 1e-6 ‖A‖³ (σ_min/σ_max ≥ 1e-6 roughly)
// Quadratic convergence: the iterate after a step of size s is off by about s²/2, so a step below
// 1e-7 leaves it within 5e-15 of the limit and no confirming step is needed.
constexpr double kLastStepSq = 1e-14;
// Scaling speeds up only the first steps from a far-from-orthogonal A; once a step is below 1e-2
// the unscaled step converges as fast (the same step count from any A) without ζ's two roots.
constexpr double kScaledStepSq = 1e-4;

/// One matrix's Newton iteration, advanced a step at a time so that two can run interleaved.
struct NewtonPolar {
  enum class State { running, converged, failed };
  Eigen::Matrix3d x;
  bool scaled = true;  // set by the first step's A
  State state = State::running;

  explicit NewtonPolar(const Eigen::Matrix3d& a) : x(a) {}

  /// Step `it` (0 first): X <- (ζ X + ζ⁻¹ X^{-T}) / 2, then whether the iteration goes on.
  [[gnu::always_inline]] inline void step(int it) {
    // X^{-T} = cof(X) / det X, the cofactor columns being cross products of X's columns.
    Eigen::Matrix3d cof;
    cof.col(0) = x.col(1).cross(x.col(2));
    cof.col(1) = x.col(2).cross(x.col(0));
    cof.col(2) = x.col(0).cross(x.col(1));
    const double det = x.col(0).dot(cof.col(0));
    const double norm_sq = x.squaredNorm();
    if (!(det > 1e-6 * norm_sq * std::sqrt(norm_sq))) {  // inverted, flat or NaN: SVD
      state = State::failed;
      return;
    }
    // An A within about 1 % of a rotation (‖A‖² ≈ 3, det A ≈ 1, a tet's F) needs no scaling at all.
    if (it == 0) scaled = !(std::abs(norm_sq - 3.0) < 0.03 && std::abs(det - 1.0) < 0.01);
    Eigen::Matrix3d next;
    if (scaled) {
      // ζ = (‖X^{-T}‖ / ‖X‖)^{1/2} = (‖cof X‖² / (det² ‖X‖²))^{1/4}.
      const double zeta = std::sqrt(std::sqrt(cof.squaredNorm() / (det * det * norm_sq)));
      next = (0.5 * zeta) * x + (0.5 / (zeta * det)) * cof;
    } else {
      next = 0.5 * x + (0.5 / det) * cof;
    }
    const double step_sq = (next - x).squaredNorm();
    x = next;
    if (step_sq < kLastStepSq) {
      state = State::converged;
      return;
    }
    scaled = step_sq >= kScaledStepSq;
    if (it + 1 == kMaxIterations) state = State::failed;
  }
  bool running() const { return state == State::running; }
  Eigen::Matrix3d result(const Eigen::Matrix3d& a) const { return state == State::converged ? x : polar_rotation(a); }
};

}  // namespace

Eigen::Matrix3d polar_rotation_newton(const Eigen::Matrix3d& a) {
  NewtonPolar p(a);
  for (int it = 0; p.running(); ++it) p.step(it);
  return p.result(a);
}

void polar_rotation_newton(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b, Eigen::Matrix3d& ra,
                           Eigen::Matrix3d& rb) {
  NewtonPolar p(a), q(b);
  // Two independent chains of dependent divisions and roots: interleaved, each hides the other's latency.
  for (int it = 0; p.running() || q.running(); ++it) {
    if (p.running()) p.step(it);
    if (q.running()) q.step(it);
  }
  ra = p.result(a);
  rb = q.result(b);
}

}  // namespace ccfr::xpbd
