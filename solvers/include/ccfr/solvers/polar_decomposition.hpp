#pragma once
/// @file polar_decomposition.hpp
/// The rotation of the polar decomposition A = R S of a 3 x 3 matrix, by the SVD and by Higham's
/// scaled Newton iteration (solvers/src/polar_decomposition.cpp).
#include <Eigen/Core>

namespace ccfr {

namespace xpbd {

/// Rotation part of the polar decomposition \f$\mathbf{A} = \mathbf{R}\mathbf{S}\f$ from the SVD
/// \f$\mathbf{A} = \mathbf{U}\boldsymbol{\Sigma}\mathbf{V}^T\f$: \f$\mathbf{R} = \mathbf{U}\,\mathrm{diag}(1, 1,
/// \det(\mathbf{U}\mathbf{V}^T))\,\mathbf{V}^T\f$, so det R = +1 even for reflections or rank-deficient A (flat or
/// collinear bodies).
Eigen::Matrix3d polar_rotation(const Eigen::Matrix3d& a);

/// The same rotation by Higham's scaled Newton iteration (Higham 1986, "Computing the polar
/// decomposition with applications"): \f$\mathbf{X}_0 = \mathbf{A}\f$, \f$\mathbf{X}_{k+1} =
/// \tfrac12(\zeta_k\mathbf{X}_k + \zeta_k^{-1}\mathbf{X}_k^{-T})\f$ with \f$\zeta_k = (\|\mathbf{X}_k^{-1}\|_F /
/// \|\mathbf{X}_k\|_F)^{1/2}\f$ while the steps are at least 1e-2 and \f$\zeta_k = 1\f$ after, or from the start for an
/// A within about 1 % of a rotation (Higham's advice: scaling helps only far from convergence; the step
/// count is the same), until the step is below 1e-7 (quadratic
/// convergence leaves the last iterate within about 5e-15 of the limit: 3-4 steps for a tet's F, 4-5x cheaper than the
/// SVD and equal to it within a few ulps). The iteration yields the orthogonal factor with det = sign det A, so an
/// inverted, flat or nearly flat A (det A ≤ 1e-6 ‖A‖³) goes to polar_rotation() instead.
Eigen::Matrix3d polar_rotation_newton(const Eigen::Matrix3d& a);

/// polar_rotation_newton() of two matrices at once: `ra` of `a` and `rb` of `b`, bit-identical to two
/// calls. The two iterations run step by step interleaved, so each one's divisions and square roots
/// wait while the other's arithmetic runs (two tets of one colour, TetBatch::solve_in_order).
void polar_rotation_newton(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b, Eigen::Matrix3d& ra,
                           Eigen::Matrix3d& rb);

}  // namespace xpbd

}  // namespace ccfr
