#pragma once
/// @file materials/tet_elasticity.hpp
/// The material constraint `tet_elasticity` of tet solids: the volume and deviatoric (co-rotational)
/// constraints with their gradients, their XPBD kernels and the batch (solvers/src/materials/tet_elasticity.cpp).
#include <array>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "ccfr/core/types.hpp"
#include "ccfr/solvers/material_constraint.hpp"
#include "ccfr/solvers/xpbd.hpp"

namespace ccfr {

namespace xpbd {

/// Six times the signed volume, \f$6V = (\mathbf{x}_1 - \mathbf{x}_0) \cdot ((\mathbf{x}_2 - \mathbf{x}_0) \times
/// (\mathbf{x}_3 - \mathbf{x}_0))\f$ (positive for a positively oriented tet).
double tet_six_volume(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3);

/// Volume constraint \f$C_V = 6(V - V_0)\f$ and its gradient:
/// \f$\nabla_1 C_V = (\mathbf{x}_2 - \mathbf{x}_0)\times(\mathbf{x}_3 - \mathbf{x}_0)\f$,
/// \f$\nabla_2 C_V = (\mathbf{x}_3 - \mathbf{x}_0)\times(\mathbf{x}_1 - \mathbf{x}_0)\f$,
/// \f$\nabla_3 C_V = (\mathbf{x}_1 - \mathbf{x}_0)\times(\mathbf{x}_2 - \mathbf{x}_0)\f$,
/// \f$\nabla_0 C_V = -\sum_{k=1}^3 \nabla_k C_V\f$. Defined (and finite) for inverted and flat tets.
double tet_volume_constraint(const std::array<Vec3, 4>& x, double rest_volume, std::array<Vec3, 4>& grad);

/// Volume preservation: \f$C_V = 6(V - V_0)\f$, compliance α in m⁶/J (MaterialSystem uses
/// α = 36 V_0 · volume_compliance with volume_compliance = 1/λ in 1/Pa). Inverted tets are pushed back
/// toward V_0 > 0; a flat tet with a vanishing gradient (all points coincident or collinear) is skipped.
void solve_tet_volume(const std::array<Vec3*, 4>& x, const std::array<double, 4>& w, double rest_volume,
                      double alpha_tilde, double& lambda);

/// Deviatoric (co-rotational shape) constraint \f$C_D = \|\mathbf{F} - \mathbf{R}\|_F\f$ with
/// \f$\mathbf{F} = \mathbf{D}_s \mathbf{D}_m^{-1}\f$, \f$\mathbf{D}_s = [\mathbf{x}_1 - \mathbf{x}_0,\ \mathbf{x}_2 -
/// \mathbf{x}_0,\ \mathbf{x}_3 - \mathbf{x}_0]\f$ (3 by 3), `rest_inverse` = \f$\mathbf{D}_m^{-1}\f$ of the rest shape
/// and R = `polar_rotation_newton`(F) (det R = +1). Its energy \f$\tfrac12 C_D^2/\alpha\f$ is the as-rigid-as-possible
/// / co-rotational energy; since R minimises \f$\|\mathbf{F} - \mathbf{R}\|\f$ over rotations, \f$\partial
/// C_D/\partial\mathbf{F} = (\mathbf{F} - \mathbf{R})/C_D\f$, and the gradient is given by the columns of \f$\mathbf{H}
/// = (\mathbf{F} - \mathbf{R})\mathbf{D}_m^{-T} / C_D\f$ for x_1..x_3, \f$\nabla_0 C_D = -\sum_k \mathbf{H}_{:,k}\f$.
/// Unlike \f$\|\mathbf{F}\|_F - \sqrt{3}\f$ (the stable Neo-Hookean term shifted to vanish at rest), it resists
/// shear to first order. Returns false when C_D = 0 (a rotation: satisfied, direction undefined like a
/// zero-length distance constraint); inverted tets get R with det +1 and are pushed back to positive volume.
bool tet_deviatoric_constraint(const std::array<Vec3, 4>& x, const Eigen::Matrix3d& rest_inverse, double& c,
                               std::array<Vec3, 4>& grad);

/// Deviatoric (shape) term: \f$C_D = \|\mathbf{F} - \mathbf{R}\|_F\f$, compliance α in 1/J (MaterialSystem uses
/// α = shear_compliance / V_0 with shear_compliance = 1/μ in 1/Pa). Finite for inverted and flat tets.
void solve_tet_deviatoric(const std::array<Vec3*, 4>& x, const std::array<double, 4>& w,
                          const Eigen::Matrix3d& rest_inverse, double alpha_tilde, double& lambda);

/// solve_tet_deviatoric() of two tets without a common vertex, bit-identical to the two calls in
/// either order: their polar decompositions run interleaved (polar_rotation_newton of two matrices).
void solve_tet_deviatoric_pair(const std::array<Vec3*, 4>& xa, const std::array<double, 4>& wa,
                               const Eigen::Matrix3d& rest_inverse_a, double alpha_tilde_a, double& lambda_a,
                               const std::array<Vec3*, 4>& xb, const std::array<double, 4>& wb,
                               const Eigen::Matrix3d& rest_inverse_b, double alpha_tilde_b, double& lambda_b);

}  // namespace xpbd

/// Volume and deviatoric constraints per tet (the material constraint `tet_elasticity`; ids(t): its
/// four vertices), solved back to back (deviatoric first, volume last so the incompressibility term
/// has the final word within a sweep); both share one colouring.
struct TetBatch final : FixedArityBatch<4> {
  std::vector<double> rest_volume;                       ///< #T, V_0 (m³)
  std::vector<Eigen::Matrix3d> rest_inverse;             ///< #T, D_m^{-1} (1/m)
  std::vector<double> volume_compliance;                 ///< #T, α_V = 36 V_0 / λ (m⁶/J)
  std::vector<double> deviatoric_compliance;             ///< #T, α_D = 1 / (μ V_0) (1/J)
  std::vector<double> lambda_volume, lambda_deviatoric;  ///< #T each

  /// Adds a tet with per-volume compliances (1/λ and 1/μ, 1/Pa) from its rest positions `rest` (#V).
  /// Returns false and adds nothing when the rest tet is degenerate (|6 V_0| tiny against its edges³).
  bool add(const Vec4i& v, const Positions& rest, double volume_compliance_per_volume,
           double shear_compliance_per_volume);
  void reset_multipliers() override;
  void solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> inv_mass, double dt) override;
  double unit_cost() const override { return 10.0; }
  int sweep_rank() const override { return 40; }
};

}  // namespace ccfr
