#pragma once
/// @file xpbd.hpp
/// The XPBD update of one scalar constraint (Macklin et al. 2016, Eq. 18), which every material
/// constraint's kernel applies:
/// \f[ \Delta\lambda = \frac{-C - \tilde\alpha\lambda}{\sum_i w_i \|\nabla_i C\|^2 + \tilde\alpha}, \qquad
///     \mathbf{x}_i \mathrel{+}= w_i \nabla_i C\, \Delta\lambda, \qquad \tilde\alpha = \alpha / \Delta t^2 \f]
/// It writes only vertices with \f$w_i > 0\f$, so kinematic vertices shared by constraints of one
/// colour are never written concurrently. Each constraint lives beside its math in
/// ccfr/solvers/materials/<key>.hpp (C(x), gradient, kernel, batch); the batches and their colouring
/// in material_constraint.hpp, the system that sweeps them in material_system.hpp. Degenerate
/// configurations (zero-area triangles, collinear strand points, collapsed tets) skip the update
/// instead of producing NaN. See docs/materials.md.
#include <array>

#include "ccfr/core/types.hpp"

namespace ccfr {

namespace xpbd {

/// Applies one XPBD update for a scalar constraint of `N` vertices given its value and gradient.
/// Returns Δλ (0 when every vertex is kinematic or the gradient vanishes). Always inlined: the
/// kernels' updates are short chains of dependent arithmetic that only run side by side inline.
template <int N>
[[gnu::always_inline]] inline double apply_update(const std::array<Vec3*, N>& x, const std::array<double, N>& w,
                                                  const std::array<Vec3, N>& grad, double c, double alpha_tilde,
                                                  double& lambda) {
  double denom = alpha_tilde;
  for (int k = 0; k < N; ++k) denom += w[k] * grad[k].squaredNorm();
  if (!(denom > 0.0)) return 0.0;
  const double dl = (-c - alpha_tilde * lambda) / denom;
  lambda += dl;
  for (int k = 0; k < N; ++k)
    if (w[k] > 0.0) *x[k] += (w[k] * dl) * grad[k];
  return dl;
}

}  // namespace xpbd

}  // namespace ccfr
