#pragma once
/// @file materials/strand_bending.hpp
/// The material constraint `strand_bending` of strands: the turning angle at an interior polyline
/// vertex, its gradient, the XPBD kernel and its batch (solvers/src/materials/strand_bending.cpp).
#include <array>
#include <span>
#include <vector>

#include "ccfr/core/types.hpp"
#include "ccfr/solvers/material_constraint.hpp"
#include "ccfr/solvers/xpbd.hpp"

namespace ccfr {

namespace xpbd {

/// Turning angle at x_1 of the polyline x_0, x_1, x_2: the angle between \f$\mathbf{e}_1 = \mathbf{x}_1 -
/// \mathbf{x}_0\f$ and \f$\mathbf{e}_2 = \mathbf{x}_2 - \mathbf{x}_1\f$, \f$\varphi =
/// \operatorname{atan2}(|\mathbf{e}_1 \times \mathbf{e}_2|, \mathbf{e}_1 \cdot \mathbf{e}_2) \in [0, \pi]\f$ (0 for a
/// straight strand). Returns 0 for zero-length segments.
double turning_angle(const Vec3& x0, const Vec3& x1, const Vec3& x2);

/// φ (as `turning_angle`) and its gradient with respect to (x_0, x_1, x_2): with unit directions
/// \f$\mathbf{u} = \hat{\mathbf{e}}_1\f$, \f$\mathbf{v} = \hat{\mathbf{e}}_2\f$,
/// \f$\mathbf{p}_1 = (\mathbf{v} - (\mathbf{u}\cdot\mathbf{v})\mathbf{u}) / \sin\varphi\f$,
/// \f$\mathbf{p}_2 = (\mathbf{u} - (\mathbf{u}\cdot\mathbf{v})\mathbf{v}) / \sin\varphi\f$:
/// \f[ \nabla_0\varphi = \frac{\mathbf{p}_1}{|\mathbf{e}_1|},\quad \nabla_2\varphi =
/// -\frac{\mathbf{p}_2}{|\mathbf{e}_2|},\quad
///     \nabla_1\varphi = -\nabla_0\varphi - \nabla_2\varphi. \f]
/// Returns false when a segment has zero length or the points are collinear (sin φ = 0): φ is not
/// differentiable there (a cone point, like a distance constraint at zero length).
bool turning_angle_gradient(const Vec3& x0, const Vec3& x1, const Vec3& x2, double& phi, std::array<Vec3, 3>& grad);

/// Strand bending: \f$C = \varphi - \varphi_0\f$ on consecutive segments, compliance α in rad²/J = 1/(N·m).
/// For a straight rest shape (φ_0 = 0) this is a cone constraint whose correction always straightens
/// the strand; collinear current points have C = -φ_0 ≤ 0 with no defined direction and are skipped.
void solve_strand_bending(const std::array<Vec3*, 3>& x, const std::array<double, 3>& w, double rest_angle,
                          double alpha_tilde, double& lambda);

}  // namespace xpbd

/// Turning-angle bending at interior polyline vertices (the material constraint `strand_bending`):
/// ids(c) = (x_{i-1}, x_i, x_{i+1}).
struct StrandBendingBatch final : FixedArityBatch<3> {
  std::vector<double> rest_angle;  ///< #C, φ_0 (rad) from the rest state
  std::vector<double> compliance;  ///< #C, α (1/(N·m))
  std::vector<double> lambda;      ///< #C

  void add(const Vec3i& v, double phi0, double alpha);
  void reset_multipliers() override;
  void solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> inv_mass, double dt) override;
  double unit_cost() const override { return 3.0; }
  int sweep_rank() const override { return 30; }
};

}  // namespace ccfr
