#include "ccfr/collision/additive_ccd.hpp"

#include <algorithm>
#include <cmath>

#include "ccfr/geometry/distance.hpp"

namespace ccfr {

namespace {

/// Stencil vertices of a sub-pair kind, and how many of them belong to side A.
int stencil_size(ContactKind kind) {
  switch (kind) {
    case ContactKind::vf:
    case ContactKind::ee:
      return 4;
    case ContactKind::ve:
      return 3;
    case ContactKind::vv:
      return 2;
  }
  return 2;
}
int stencil_side_a(ContactKind kind) { return kind == ContactKind::ee ? 2 : 1; }

double sub_pair_distance_sq(ContactKind kind, const std::array<Vec3, 4>& x) {
  switch (kind) {
    case ContactKind::vf:
      return point_triangle(x[0], x[1], x[2], x[3]).distance_sq;
    case ContactKind::ee:
      return edge_edge(x[0], x[1], x[2], x[3]).distance_sq;
    case ContactKind::ve:
      return point_edge(x[0], x[1], x[2]).distance_sq;
    case ContactKind::vv:
      return point_point_distance_sq(x[0], x[1]);
  }
  return point_point_distance_sq(x[0], x[1]);
}

/// g = d - ξ written as (d² - ξ²) / (d + ξ): the closest-point routines give d², and near contact
/// the difference of squares keeps the digits that sqrt(d²) - ξ would cancel. At d = ξ = 0 the
/// gap is 0 (a point pair with no separation required only touches when it coincides).
double gap_of(double d_sq, double xi) {
  const double d = std::sqrt(d_sq);
  const double denom = d + xi;
  return denom > 0.0 ? (d_sq - xi * xi) / denom : 0.0;
}

}  // namespace

double sub_pair_distance(ContactKind kind, const std::array<Vec3, 4>& x) {
  return std::sqrt(sub_pair_distance_sq(kind, x));
}

AccdResult additive_ccd(ContactKind kind, const std::array<Vec3, 4>& x0, const std::array<Vec3, 4>& x1,
                        double min_separation, const AdditiveCcdParams& params) {
  const int n = stencil_size(kind), na = stencil_side_a(kind);
  const double xi = min_separation, s = params.scale;
  AccdResult res;

  std::array<Vec3, 4> p;
  Vec3 mean = Vec3::Zero();
  for (int k = 0; k < n; ++k) mean += (p[k] = x1[k] - x0[k]);
  mean /= n;
  double max_a = 0.0, max_b = 0.0;
  for (int k = 0; k < n; ++k) {
    double& side_max = k < na ? max_a : max_b;
    side_max = std::max(side_max, (p[k] - mean).norm());
  }
  const double l_p = max_a + max_b;

  const double gap0 = gap_of(sub_pair_distance_sq(kind, x0), xi);
  if (!(gap0 > params.touch_tolerance * xi)) {  // touching or inside ξ already (or NaN): no conservative step
    res.toi = 0.0;
    res.impact = true;
    return res;
  }
  if (l_p <= 0.0) return res;  // a rigid translation of the stencil never changes its distance

  const double stop_gap = (1.0 - s) * gap0;
  double t = 0.0, gap = gap0;
  std::array<Vec3, 4> xt = x0;
  for (int it = 0; it < params.max_iterations; ++it) {
    const double step = s * gap / l_p;
    if (t + step >= 1.0) {  // the bound holds up to t + step: no impact within [0, 1]
      res.toi = 1.0;
      res.iterations = it;
      return res;
    }
    const double t_next = t + step;
    // Positions from x0 at each trial time instead of accumulated increments: no drift.
    for (int k = 0; k < n; ++k) xt[k] = x0[k] + t_next * p[k];
    const double gap_next = gap_of(sub_pair_distance_sq(kind, xt), xi);
    res.iterations = it + 1;
    // Stop at the last time whose gap is still (1 - s) g(0): the next outer iteration then starts
    // from a positive gap. The first step is always kept (its gap is >= (1 - s) g(0) by the bound;
    // only rounding can put it below).
    if (t > 0.0 && gap_next < stop_gap) break;
    t = t_next;
    gap = gap_next;
    if (!(gap > 0.0)) break;  // rounding at a vanishing gap: t is the last safe time reached
  }
  res.toi = t;
  res.impact = true;
  return res;
}

}  // namespace ccfr
