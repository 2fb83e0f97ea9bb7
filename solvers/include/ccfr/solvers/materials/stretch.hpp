#pragma once
/// @file materials/stretch.hpp
/// The material constraint `stretch`: edge lengths of cloth, shells and strands, the distance
/// constraint's XPBD kernel and its batch (solvers/src/materials/stretch.cpp).
#include <span>
#include <vector>

#include "ccfr/core/types.hpp"
#include "ccfr/solvers/material_constraint.hpp"
#include "ccfr/solvers/xpbd.hpp"

namespace ccfr {

namespace xpbd {

/// Distance constraint \f$C = \|\mathbf{x}_i - \mathbf{x}_j\| - L\f$ with compliance \f$\alpha\f$:
/// \f$\Delta\lambda = (-C - \tilde\alpha\lambda)/(w_i + w_j + \tilde\alpha)\f$, \f$\tilde\alpha = \alpha/\Delta t^2\f$
/// (Macklin et al. 2016, Eq. 18). Updates x_i, x_j and λ in place.
inline void solve_distance(Vec3& xi, Vec3& xj, double wi, double wj, double rest, double alpha_tilde, double& lambda) {
  const double wsum = wi + wj + alpha_tilde;
  if (wsum <= 0.0) return;
  Vec3 d = xi - xj;
  const double len = d.norm();
  if (len < 1e-12) return;  // direction undefined: leave to neighbouring constraints
  d /= len;
  const double c = len - rest;
  const double dl = (-c - alpha_tilde * lambda) / wsum;
  lambda += dl;
  // Kinematic vertices (w = 0) may be shared within a colour: never write them.
  if (wi > 0.0) xi += wi * dl * d;
  if (wj > 0.0) xj -= wj * dl * d;
}

}  // namespace xpbd

/// A colour of a distance batch is split into parallel tasks only beyond this many constraints;
/// smaller colours run inline on the calling thread.
inline constexpr Index kDistanceGrain = 512;

/// Edge length constraints (the material constraint `stretch`).
struct DistanceBatch final : FixedArityBatch<2> {
  std::vector<double> rest;
  std::vector<double> compliance;
  std::vector<double> lambda;

  void add(Index i, Index j, double rest_length, double alpha);
  void reset_multipliers() override;
  void solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> inv_mass, double dt) override;
  Index grain() const override { return kDistanceGrain; }
  int sweep_rank() const override { return 10; }
};

}  // namespace ccfr
