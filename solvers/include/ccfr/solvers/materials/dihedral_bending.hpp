#pragma once
/// @file materials/dihedral_bending.hpp
/// The material constraint `dihedral_bending` of cloth and shells: the dihedral angle across an
/// interior edge, its gradient, the XPBD kernel and its batch (solvers/src/materials/dihedral_bending.cpp).
#include <array>
#include <span>
#include <vector>

#include "ccfr/core/types.hpp"
#include "ccfr/solvers/material_constraint.hpp"
#include "ccfr/solvers/xpbd.hpp"

namespace ccfr {

namespace xpbd {

/// Signed dihedral angle \f$\theta \in (-\pi, \pi]\f$ across the edge \f$(\mathbf{x}_0, \mathbf{x}_1)\f$
/// shared by the triangles \f$(\mathbf{x}_0, \mathbf{x}_1, \mathbf{x}_2)\f$ and \f$(\mathbf{x}_0, \mathbf{x}_3,
/// \mathbf{x}_1)\f$: with \f$\mathbf{e} = \mathbf{x}_1 - \mathbf{x}_0\f$, \f$\mathbf{n}_1 = \mathbf{e} \times
/// (\mathbf{x}_2 - \mathbf{x}_0)\f$, \f$\mathbf{n}_2 = (\mathbf{x}_3 - \mathbf{x}_0) \times \mathbf{e}\f$, \f[ \theta =
/// \operatorname{atan2}\big((\hat{\mathbf{n}}_1 \times \hat{\mathbf{n}}_2) \cdot \hat{\mathbf{e}},\;
///     \hat{\mathbf{n}}_1 \cdot \hat{\mathbf{n}}_2\big). \f]
/// A flat pair (x_2 and x_3 on opposite sides of the edge) has θ = 0. Returns 0 for degenerate triangles.
double dihedral_angle(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3);

/// θ (as `dihedral_angle`) and its gradient with respect to (x_0, x_1, x_2, x_3) (Bridson et al. 2003):
/// \f[ \nabla_2\theta = -\frac{|\mathbf{e}|}{|\mathbf{n}_1|^2}\mathbf{n}_1,\quad
///     \nabla_3\theta = -\frac{|\mathbf{e}|}{|\mathbf{n}_2|^2}\mathbf{n}_2,\quad
///     \nabla_0\theta = -\frac{(\mathbf{x}_2 -
///     \mathbf{x}_1)\cdot\mathbf{e}}{|\mathbf{e}|\,|\mathbf{n}_1|^2}\mathbf{n}_1
///                      -\frac{(\mathbf{x}_3 -
///                      \mathbf{x}_1)\cdot\mathbf{e}}{|\mathbf{e}|\,|\mathbf{n}_2|^2}\mathbf{n}_2,\quad
///     \nabla_1\theta = -\nabla_0\theta - \nabla_2\theta - \nabla_3\theta. \f]
/// Returns false (grad untouched) when the edge or either triangle is degenerate: the gradient
/// grows as 1/height and is undefined at zero area.
bool dihedral_angle_gradient(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3, double& theta,
                             std::array<Vec3, 4>& grad);

/// Dihedral bending (Müller et al. 2007, in XPBD form): \f$C = \operatorname{wrap}(\theta - \theta_0)\f$ with
/// wrap into \f$(-\pi, \pi]\f$, compliance α in rad²/J = 1/(N·m). x = (x_0, x_1, x_2, x_3) as in
/// `dihedral_angle`. Skips degenerate triangles.
void solve_dihedral_bending(const std::array<Vec3*, 4>& x, const std::array<double, 4>& w, double rest_angle,
                            double alpha_tilde, double& lambda);

}  // namespace xpbd

/// Dihedral bending on interior edges (the material constraint `dihedral_bending`):
/// ids(c) = (edge v0, edge v1, wing of face 1, wing of face 2), the vertex order of `xpbd::dihedral_angle`.
struct BendingBatch final : FixedArityBatch<4> {
  std::vector<double> rest_angle;  ///< #C, θ_0 (rad) from the rest state
  std::vector<double> compliance;  ///< #C, α (1/(N·m))
  std::vector<double> lambda;      ///< #C

  void add(const Vec4i& v, double theta0, double alpha);
  void reset_multipliers() override;
  void solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> inv_mass, double dt) override;
  double unit_cost() const override { return 4.0; }
  int sweep_rank() const override { return 20; }
};

}  // namespace ccfr
