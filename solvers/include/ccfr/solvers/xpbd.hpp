#pragma once
/// @file xpbd.hpp
/// XPBD material constraints as batches (struct of arrays per type) with stateless kernels.
/// Batches are graph-coloured once from the static topology: constraints of one colour share no
/// vertex and are solved in parallel, colours in sequence (Gauss-Seidel across colours), which is
/// deterministic for any thread count.
#include <span>
#include <vector>

#include "ccfr/core/types.hpp"

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

/// Greedy colouring of constraints given by their vertex lists (`arity` vertices each, flat array).
/// Returns the colours' row starts into `order` (constraints grouped by colour).
struct Colouring {
  std::vector<Index> order;      ///< constraint ids grouped by colour
  std::vector<Index> row_start;  ///< #colours + 1
  Index colours() const { return static_cast<Index>(row_start.size()) - 1; }
};
Colouring colour_constraints(Index num_vertices, std::span<const Index> vertices, int arity,
                             std::span<const double> inv_mass);

/// A colour of a distance batch is split into parallel tasks only beyond this many constraints;
/// smaller colours run inline on the calling thread.
inline constexpr Index kDistanceGrain = 512;

/// Edge length constraints.
struct DistanceBatch {
  std::vector<Vec2i> ids;
  std::vector<double> rest;
  std::vector<double> compliance;
  std::vector<double> lambda;
  Colouring colouring;

  void add(Index i, Index j, double rest_length, double alpha);
  /// Colours the batch (call after the last add()).
  void finalize(Index num_vertices, std::span<const double> inv_mass);
  void reset_multipliers();
  /// One sweep over `colouring`: colours in sequence, each colour a parallel loop.
  void solve(Positions& x, std::span<const double> inv_mass, double dt) { solve(colouring, x, inv_mass, dt); }
  /// The same over `col`, a colouring of any subset of the constraints (grouped as in `colouring`).
  void solve(const Colouring& col, Positions& x, std::span<const double> inv_mass, double dt);
  /// The constraints `order` one after another on the calling thread (the kernel loop of every schedule).
  void solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> inv_mass, double dt);
  Index size() const { return static_cast<Index>(ids.size()); }
};

}  // namespace ccfr
