#pragma once
/// @file shape_matching.hpp
/// Shape matching of rigid bodies (Müller et al. 2005): the kernel of one body and the batch of every
/// rigid body of a scene, with its rigid prediction (solvers/src/shape_matching.cpp).
#include <span>
#include <vector>

#include "ccfr/core/types.hpp"

namespace ccfr {

namespace xpbd {

/// Shape matching (Müller et al. 2005) with stiffness 1 of one body of n vertices. With weights
/// \f$m_i\f$, rest offsets \f$\mathbf{q}_i = \bar{\mathbf{x}}_i - \bar{\mathbf{c}}\f$ about the weighted rest centre,
/// \f$\mathbf{c} = \sum_i m_i \mathbf{x}_i / \sum_i m_i\f$, \f$\mathbf{A}_{pq} = \sum_i m_i (\mathbf{x}_i -
/// \mathbf{c})\mathbf{q}_i^T\f$ and R = `polar_rotation`(A_pq), every vertex with \f$w_i > 0\f$ moves to its goal
/// \f$\mathbf{g}_i = \mathbf{R}\mathbf{q}_i + \mathbf{c}\f$ (the constraint \f$\mathbf{C}_i = \mathbf{x}_i -
/// \mathbf{g}_i = 0\f$ projected exactly). x, w: #n; q, m: #n. Sums run in vertex order, so the result does not depend
/// on threads.
void solve_shape_matching(std::span<Vec3> x, std::span<const double> w, std::span<const Vec3> q,
                          std::span<const double> m);

}  // namespace xpbd

/// Shape matching of rigid bodies; body b owns the contiguous vertices [begin[b], end[b]) and the
/// entries [row_start[b], row_start[b+1]) of `rest_offset` and `weight`. Bodies are disjoint, so they are
/// solved in parallel, each one sequentially.
struct ShapeMatchingBatch {
  std::vector<Index> begin, end;  ///< #B vertex ranges
  std::vector<Index> row_start;   ///< #B + 1
  std::vector<Vec3> rest_offset;  ///< q_i = rest_i - weighted rest centre (m)
  std::vector<double> weight;     ///< m_i: mass 1/w_i of dynamic vertices; kinematic vertices dominate (see docs)

  /// Adds the body made of vertices [first, last) with rest positions `rest` and inverse masses `inv_mass` (#V).
  void add(Index first, Index last, const Positions& rest, std::span<const double> inv_mass);
  void solve(Positions& x, std::span<const double> inv_mass) const;
  /// Rigid prediction: every body without kinematic vertices repeats the rigid motion of its
  /// last substep, read from `x` and `x - dt v` (its centre moves by dt v_c + `g_dt2`, its
  /// rotation turns again by the last substep's ΔR), into `predicted`. The per-vertex prediction
  /// x + dt v followed by shape matching turns by θ - 2θ³/3 instead of θ = ω dt, which bled
  /// 2θ²/3 of the spin per substep (a tenth of a 10 rad/s spin per second at 480 substeps/s).
  void predict(const Positions& x, const Positions& v, std::span<const double> inv_mass, double dt, const Vec3& g_dt2,
               Positions& predicted) const;
  Index size() const { return static_cast<Index>(begin.size()); }
};

}  // namespace ccfr
