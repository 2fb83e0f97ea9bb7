#pragma once
/// @file ogc.hpp
/// `ogc`: the conservative per-vertex displacement bounds of Offset Geometric Contact (Chen, Hsu,
/// Liu, Macklin, Yang, Yuksel, ACM TOG 44(4):160, 2025; ipc-toolkit `ipc::ogc::TrustRegion::
/// filter_step`) on the trust region of TrustRegionSolver (trust_region_solver.hpp). See docs/methods.md.
#include <span>
#include <vector>

#include "ccfr/solvers/trust_region_solver.hpp"

namespace ccfr {

/// Offset Geometric Contact's conservative bounds (factory name `ogc`).
///
/// For each movable vertex v, with \f$P(v)\f$ the detected sub-pairs that contain v (as the
/// vertex, or as a vertex of the edge or face), \f$d_c\f$ a pair's distance at detection,
/// \f$\xi_c\f$ its offset and \f$K_c\f$ the scripted motion of its vertices in this pass,
/// \f[ b_v = \gamma_p \min\Big(r_q - \xi,\ \min_{c \in P(v)} \big(d_c - \xi_c - K_c\big)^+\Big) \f]
/// (OGC's per-vertex bound \f$b_v = \gamma_p \min(d_{\min,v}, d_{\min,e}, d_{\min,t})\f$ over the
/// vertex's own and its adjacent edges' and faces' nearest non-adjacent primitives, the paper's
/// vertex-specific displacement bounds; here measured beyond the offset ξ instead of beyond contact), and resolve()
/// sets \f$\mathbf{x}_v \leftarrow \mathbf{c}_v + b_v\,\Delta\mathbf{x}/\|\Delta\mathbf{x}\|\f$ when
/// \f$\|\Delta\mathbf{x}\| = \|\mathbf{x}_v - \mathbf{c}_v\| > b_v\f$.
///
/// Why every pair keeps ≥ ξ_c (our adaptation of the paper's proof): each point of a primitive is
/// a convex combination of its vertices, so it moves at most the largest displacement among them.
/// Each movable vertex of pair c moves at most \f$\gamma_p(d_c - \xi_c - K_c)\f$ and each scripted
/// one at most its side's share of \f$K_c\f$, so the closest points approach by at most
/// \f$2\gamma_p(d_c - \xi_c - K_c) + K_c \le d_c - \xi_c\f$ for \f$\gamma_p \le 1/2\f$: the
/// distance stays ≥ ξ_c. A pair not detected was at least ξ + 2r ≥ r_q apart, and its two sides
/// move at most \f$2\gamma_p(r_q - \xi) < r_q - \xi\f$ (plus a scripted step ≤ r, which the loop
/// enforces, against 2r of spare range): it stays ≥ ξ too.
class OffsetGeometricContactSolver final : public TrustRegionSolver {
 public:
  explicit OffsetGeometricContactSolver(TrustRegionParams params = {}) : TrustRegionSolver(params) {}
  std::string_view name() const override { return "ogc"; }
  /// b_v of the last detection (#V; scripted and fixed vertices keep r_q's bound, unused).
  std::span<const double> bounds() const { return bounds_; }

 protected:
  void build_limits(std::span<const double> inv_mass, std::span<const Vec3> kinematic) override;
  bool truncate(Index v, Vec3& x) const override;
  bool within(Index v, const Vec3& p) const override;

 private:
  std::vector<double> bounds_;
};

}  // namespace ccfr
