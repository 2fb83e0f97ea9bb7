#pragma once
/// @file additive_ccd.hpp
/// Additive CCD (Li et al. 2021): conservative advancement with a distance lower bound, for the
/// sub-pairs of the narrow phase (ContactKind). Used by the `toi_clamp` contact solver.
#include <array>

#include "ccfr/collision/collision_detector.hpp"

namespace ccfr {

/// Parameters of Additive CCD.
struct AdditiveCcdParams {
  /// s in (0, 1]: each advancement covers the fraction s of what the distance bound allows, and the
  /// search stops once the gap has shrunk below (1 - s) of its initial value. s = 1 is exact in
  /// the limit of many iterations but may return a time at which the gap is zero.
  double scale = 0.9;
  /// Advancement steps per pair before giving up with the (still safe) time reached so far.
  int max_iterations = 1000;
  /// A pair whose initial gap d - ξ is at most this fraction of ξ counts as touching and gets
  /// toi = 0 at once: from such a gap the advancement moves by at most ~1e-9 of the step in
  /// max_iterations steps anyway, and the relative rounding of the distance is of this order
  /// (ipc-toolkit stops the same way below machine epsilon).
  double touch_tolerance = 1e-12;
};

/// Result of one Additive CCD query.
struct AccdResult {
  double toi = 1.0;     ///< t in [0, 1]: the pair keeps a distance > ξ on [0, t] (t = 1: no impact)
  int iterations = 0;   ///< advancement steps taken
  bool impact = false;  ///< the search stopped before t = 1 (toi < 1)
};

/// Distance of the sub-pair `kind` between its primitives at the stencil positions `x`
/// (vf: point x0, triangle x1 x2 x3; ee: edges (x0, x1) and (x2, x3); ve: point x0, segment
/// (x1, x2); vv: points x0, x1). Unused entries are ignored.
double sub_pair_distance(ContactKind kind, const std::array<Vec3, 4>& x);

/// Additive CCD (Li et al. 2021, Alg. 1) of the sub-pair `kind` whose stencil vertices move
/// linearly from `x0` to `x1`, \f$\mathbf{x}_k(t) = \mathbf{x}_k^0 + t\,\mathbf{p}_k\f$ with
/// \f$\mathbf{p}_k = \mathbf{x}_k^1 - \mathbf{x}_k^0\f$, against the minimum separation ξ.
///
/// The common translation \f$\bar{\mathbf{p}}\f$ (mean of the stencil's displacements) does not
/// change the distance and is removed first; then the closest points of the two sides approach
/// each other at most at the rate
/// \f[ l_p = \max_{k \in A} \|\mathbf{p}_k - \bar{\mathbf{p}}\| + \max_{k \in B} \|\mathbf{p}_k - \bar{\mathbf{p}}\|
/// ,\f] so \f$ d(t + \tau) \ge d(t) - \tau\, l_p \f$. With the gap \f$ g(t) = d(t) - \xi = (d^2 - \xi^2) / (d + \xi)
/// \f$ (the second form keeps the squared distance of the closest-point routines and loses no digits when d is near ξ),
/// each step \f[ t \leftarrow t + \tau,\qquad \tau = s\, \frac{g(t)}{l_p} \f] keeps \f$ g \ge (1 - s)\, g(t) > 0 \f$ on
/// the whole step. The search stops at the last time whose gap is still at least \f$ (1 - s)\, g(0) \f$ (the first step
/// is always taken), after `max_iterations` steps, or with toi = 1 once a step reaches past t = 1.
///
/// Never later than the true time of impact: d > ξ on [0, toi] whenever g(0) > 0. For a point
/// approaching a plane head-on at normal speed \f$v_n\f$ the answer is
/// \f$ s\,(d_0 - \xi)/v_n \f$. A pair already at or inside ξ (g(0) <= 0) gets toi = 0, as in
/// ipc-toolkit: no conservative step exists from there, whatever the direction of motion. So does
/// a pair whose gap is below `touch_tolerance` ξ.
AccdResult additive_ccd(ContactKind kind, const std::array<Vec3, 4>& x0, const std::array<Vec3, 4>& x1,
                        double min_separation, const AdditiveCcdParams& params = {});

}  // namespace ccfr
