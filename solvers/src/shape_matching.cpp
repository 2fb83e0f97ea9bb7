// Shape matching of rigid bodies: the exact projection onto a body's rigid placements and the
// rigid prediction of a substep.
#include "ccfr/solvers/shape_matching.hpp"

#include <algorithm>

#include <Eigen/Geometry>

#include "ccfr/core/parallel.hpp"
#include "ccfr/solvers/polar_decomposition.hpp"

namespace ccfr {

namespace xpbd {

void solve_shape_matching(std::span<Vec3> x, std::span<const double> w, std::span<const Vec3> q,
                          std::span<const double> m) {
  const size_t n = x.size();
  double total = 0.0;
  Vec3 c = Vec3::Zero();
  for (size_t i = 0; i < n; ++i) {
    total += m[i];
    c += m[i] * x[i];
  }
  if (!(total > 0.0)) return;
  c /= total;
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < n; ++i) a.noalias() += m[i] * (x[i] - c) * q[i].transpose();
  if (!a.allFinite()) return;
  const Eigen::Matrix3d r = polar_rotation(a);
  for (size_t i = 0; i < n; ++i)
    if (w[i] > 0.0) x[i] = r * q[i] + c;
}

}  // namespace xpbd

// ---- ShapeMatchingBatch -------------------------------------------------------------------------

void ShapeMatchingBatch::add(Index first, Index last, const Positions& rest, std::span<const double> inv_mass) {
  if (row_start.empty()) row_start.push_back(0);
  begin.push_back(first);
  end.push_back(last);
  double max_mass = 0.0;
  for (Index i = first; i < last; ++i) {
    if (inv_mass[i] > 0.0) max_mass = std::max(max_mass, 1.0 / inv_mass[i]);
  }
  // A kinematic vertex has infinite mass: the body must follow it. A weight 1e9 times the heaviest
  // dynamic vertex reproduces that limit to round-off while the dynamic vertices still fix the
  // rotation about axes the kinematic ones leave free (one or two pins, or collinear pins).
  const double kinematic_weight = max_mass > 0.0 ? 1e9 * max_mass : 1.0;
  const size_t base = weight.size();
  double total = 0.0;
  Vec3 centre = Vec3::Zero();
  for (Index i = first; i < last; ++i) {
    const double m = inv_mass[i] > 0.0 ? 1.0 / inv_mass[i] : kinematic_weight;
    weight.push_back(m);
    total += m;
    centre += m * rest[i];
  }
  centre /= total > 0.0 ? total : 1.0;
  for (Index i = first; i < last; ++i) rest_offset.push_back(rest[i] - centre);
  row_start.push_back(static_cast<Index>(base) + (last - first));
}

void ShapeMatchingBatch::solve(Positions& x, std::span<const double> w) const {
  parallel_for(
      size(),
      [&](Index lo, Index hi) {
        for (Index b = lo; b < hi; ++b) {
          const size_t n = static_cast<size_t>(end[b] - begin[b]);
          const size_t o = static_cast<size_t>(row_start[b]);
          xpbd::solve_shape_matching(
              std::span<Vec3>(x.data() + begin[b], n), w.subspan(static_cast<size_t>(begin[b]), n),
              std::span<const Vec3>(rest_offset.data() + o, n), std::span<const double>(weight.data() + o, n));
        }
      },
      1);
}

void ShapeMatchingBatch::predict(const Positions& x, const Positions& v, std::span<const double> inv_mass, double dt,
                                 const Vec3& g_dt2, Positions& predicted) const {
  parallel_for(
      size(),
      [&](Index lo, Index hi) {
        for (Index b = lo; b < hi; ++b) {
          const size_t n = static_cast<size_t>(end[b] - begin[b]);
          const size_t o = static_cast<size_t>(row_start[b]);
          bool dynamic = true;
          for (Index i = begin[b]; i < end[b] && dynamic; ++i) dynamic = inv_mass[i] > 0.0;
          if (!dynamic) continue;  // pinned bodies follow their pins through shape matching
          double total = 0.0;
          Vec3 c = Vec3::Zero(), c_prev = Vec3::Zero();
          for (size_t k = 0; k < n; ++k) {
            const Index i = begin[b] + static_cast<Index>(k);
            total += weight[o + k];
            c += weight[o + k] * x[i];
            c_prev += weight[o + k] * (x[i] - dt * v[i]);
          }
          c /= total;
          c_prev /= total;
          Eigen::Matrix3d a = Eigen::Matrix3d::Zero(), a_prev = Eigen::Matrix3d::Zero();
          for (size_t k = 0; k < n; ++k) {
            const Index i = begin[b] + static_cast<Index>(k);
            a.noalias() += weight[o + k] * (x[i] - c) * rest_offset[o + k].transpose();
            a_prev.noalias() += weight[o + k] * (x[i] - dt * v[i] - c_prev) * rest_offset[o + k].transpose();
          }
          const Eigen::Matrix3d r = xpbd::polar_rotation(a);
          const Eigen::Matrix3d next = r * xpbd::polar_rotation(a_prev).transpose() * r;  // ΔR R
          const Vec3 centre = 2.0 * c - c_prev + g_dt2;
          for (size_t k = 0; k < n; ++k)
            predicted[begin[b] + static_cast<Index>(k)] = next * rest_offset[o + k] + centre;
        }
      },
      1);
}

}  // namespace ccfr
