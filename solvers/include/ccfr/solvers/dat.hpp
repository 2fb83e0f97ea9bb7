#pragma once
/// @file dat.hpp
/// `dat`: planar Divide-and-Truncate (the SIGGRAPH 2026 successor of OGC, "Divide and Truncate:
/// A Penetration and Inversion Free Framework for Coupled Multi-physics Systems"; ipc-toolkit
/// `ipc::ogc::TrustRegion::planar_filter_step`) on the detection and trust region of `ogc`
/// (ogc.hpp). See docs/methods.md.
#include <span>
#include <vector>

#include "ccfr/solvers/trust_region_solver.hpp"

namespace ccfr {

/// One side of a division plane as vertex v sees it: v must keep \f$\boldsymbol\nu^\top\mathbf{x}
/// \ge \ell\f$ (ν points from the plane toward v's own primitive).
struct DivisionLimit {
  Vec3 normal = Vec3::UnitZ();
  double limit = 0.0;
};

/// Planar Divide-and-Truncate (factory name `dat`).
///
/// Each detected sub-pair c (normal n from side B to side A, offset ξ_c) gets one division plane
/// at the middle of its gap along n: with \f$\ell_A = \min_{u \in A} \mathbf{n}^\top\mathbf{c}_u\f$,
/// \f$h_B = \max_{u \in B} \mathbf{n}^\top\mathbf{c}_u\f$ over the centres (a scripted vertex counted
/// at both ends of its step) and \f$m = (\ell_A + h_B)/2\f$, side A must stay at
/// \f$\mathbf{n}^\top\mathbf{x} \ge m + \xi_c/2\f$ and side B at \f$\mathbf{n}^\top\mathbf{x} \le m - \xi_c/2\f$.
/// Relaxed as in the toolkit (a vertex covers at most 2γ_p of its way to that bound), a movable
/// vertex u of side A gets the limit
/// \f[ \mathbf{n}^\top\mathbf{x}_u \ge \mathbf{n}^\top\mathbf{c}_u - 2\gamma_p\big(\mathbf{n}^\top\mathbf{c}_u - m -
/// \xi_c/2\big)^+ \f] (side B the same with −n). resolve() removes, plane by plane, only the component of the
/// displacement that crosses a limit (the tangential part is kept: for one plane this is the
/// Euclidean projection onto its half-space, for orthogonal planes onto their intersection), up
/// to 4 cyclic sweeps; if a limit is still crossed after them, the result is pulled back along the
/// ray to the centre, which satisfies every limit. Finally, as the toolkit's isotropic fallback
/// for primitives beyond the query radius, every vertex stays within γ_p (r_q − ξ) of its centre.
///
/// Why every detected pair keeps ≥ ξ_c: n·x over a triangle, edge or point is minimised (or
/// maximised) at a vertex, so if every vertex of A stays at ≥ m + ξ_c/2 and every vertex of B at
/// ≤ m − ξ_c/2, the two primitives are at least ξ_c apart along n, hence in distance. The limits
/// keep the movable vertices there (each limit is at or beyond the bound, as 2γ_p ≤ 1) and the
/// scripted vertices were counted in ℓ_A, h_B, so when \f$\ell_A - h_B \ge \xi_c\f$ at detection
/// (a feasible anchor, \f$\ell_A - h_B = d_c\f$ for the exact closest-point normal) nothing
/// crosses. Undetected pairs are kept apart by the isotropic bound, as for `ogc`. A vertex already
/// beyond its bound where the pair needs a push (its distance at detection, less what the scripted
/// steps close along n, below (1 − debug.audit_tolerance) ξ_c) gets the bound itself as its limit,
/// so the cut pushes it out along the normal, as CCFR's half-space with a known
/// \f$\Delta\mathbf{x}_B\f$ does (Eq. 3); the centre does not satisfy that limit, so the ray
/// fallback then starts from the exact projection of the centre onto all of the vertex's limits
/// (if they admit a point; else the pushed limit is left to the sweeps). Any other vertex beyond
/// its bound keeps its centre as its limit: the pair is feasible there and only the computed
/// normal's error (\f$\ell_A - h_B\f$ a few 1e-15 below \f$d_c\f$ over a large triangle) put it
/// past, so every centre satisfies its own limits and
/// the pair keeps \f$\min(\xi_c, \ell_A - h_B)\f$ along n (docs/methods.md, the card stack).
class DivideAndTruncateSolver final : public TrustRegionSolver {
 public:
  explicit DivideAndTruncateSolver(TrustRegionParams params = {}) : TrustRegionSolver(params) {}
  std::string_view name() const override { return "dat"; }
  /// Vertex v's limits of the last detection.
  std::span<const DivisionLimit> limits(Index v) const {
    return {limits_.data() + row_start_[static_cast<size_t>(v)],
            static_cast<size_t>(row_start_[static_cast<size_t>(v) + 1] - row_start_[static_cast<size_t>(v)])};
  }
  /// Truncates the candidate `x` of a vertex whose centre is `c` against `limits` and the ball of
  /// radius `ball` around c (the resolve() rule above, exposed for tests). Returns whether x changed.
  static bool truncate_against(const Vec3& c, std::span<const DivisionLimit> limits, double ball, Vec3& x);

 protected:
  void build_limits(std::span<const double> inv_mass, std::span<const Vec3> kinematic) override;
  bool truncate(Index v, Vec3& x) const override;
  bool within(Index v, const Vec3& p) const override;

 private:
  std::vector<Index> row_start_;  ///< CSR: vertex v's limits are limits_[row_start_[v], row_start_[v+1])
  std::vector<DivisionLimit> limits_;
};

}  // namespace ccfr
