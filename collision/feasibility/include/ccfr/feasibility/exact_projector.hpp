#pragma once
/// @file exact_projector.hpp
/// The exact Euclidean projection onto a vertex's region, by enumeration of active sets.
#include "ccfr/feasibility/projector.hpp"

namespace ccfr {

/// Outcome of exact_region_projection.
struct ExactProjection {
  Vec3 p = Vec3::Zero();  ///< the projection, relative to the anchor
  bool found = false;     ///< false: no feasible point (empty region or non-finite input)
  int active = 0;         ///< size of the certified active set (0: the start point was inside)
};

/// Solves \f$\min_{\mathbf{p}} \|\mathbf{p} - \mathbf{q}\|^2\f$ subject to
/// \f$\mathbf{n}_k\cdot\mathbf{p} + d_k \ge s\f$ for every plane, in coordinates relative to the anchor
/// (\f$\mathbf{q} = \mathbf{x}' - \mathbf{x}_a\f$, margin \f$s \ge 0\f$).
///
/// In \f$\mathbb{R}^3\f$ the optimum has a KKT certificate with at most three linearly independent
/// active planes: \f$\mathbf{p} = \mathbf{q} + \sum_{i\in S}\lambda_i\mathbf{n}_i\f$, \f$\lambda \ge 0\f$,
/// equality on S, every plane satisfied. Active sets S of size 1, 2, 3 (each holding at least one plane
/// violated at q, which every optimal S does) are enumerated, the equality system solved in closed form
/// (Gram matrix for |S| <= 2, Cramer's rule for |S| = 3) and the first certified point returned;
/// the certificate makes the answer independent of how well-conditioned the subsets are.
/// Cost \f$O(m^4)\f$ in the worst case, m <= 16 in practice. If no subset certifies (only
/// near-degenerate regions at the tolerance edge), Hildreth's dual coordinate ascent decides.
/// Above 24 planes a Goldfarb-Idnani dual active-set method replaces the enumeration. When the
/// anchor violates a plane (\f$d_k < s\f$, the only case in which the region can be empty), the same
/// method first looks for a Farkas certificate, \f$\lambda \ge 0\f$ with
/// \f$\sum_k\lambda_k\mathbf{n}_k \approx 0\f$ and \f$\sum_k\lambda_k(d_k - s) < 0\f$, and reports an empty region
/// in microseconds instead of running Hildreth's 20,000 sweeps.
/// @param tolerance absolute slack of the certificate (feasibility, equalities, multipliers)
ExactProjection exact_region_projection(const Vec3& q, std::span<const HalfSpace> planes, double margin,
                                        double tolerance);

/// The exact projector ("exact"): the Euclidean projection of the candidate onto the region, then
/// the same ε treatment as Plesník's so that the two are comparable and strictly inside:
///  - anchor feasible (all \f$d_k \ge 0\f$): retract the projection by ε toward the anchor;
///  - anchor infeasible (some \f$d_k < 0\f$, clarification 7): retracting toward the anchor would
///    leave the region, so instead project onto the region shrunk by ε
///    (\f$\rho_k \ge \varepsilon\f$); when that is empty (slab thinner than ε), onto the region itself;
///  - empty region or non-finite input: status `infeasible`, x = the anchor (the vertex stays put).
/// Handles duplicated, nearly parallel and opposing planes and zero-width slabs.
class ExactProjector final : public Projector {
 public:
  explicit ExactProjector(const ProjectorParams& params = {});
  ProjectResult project(const Vec3& x_anchor, const Vec3& x_candidate,
                        std::span<const HalfSpace> planes) const override;
  std::string_view name() const override { return "exact"; }

 private:
  ProjectorParams params_;
};

}  // namespace ccfr
