#pragma once
/// @file ogc.hpp
/// `ogc`: the conservative per-vertex displacement bounds of Offset Geometric Contact (Chen, Hsu,
/// Liu, Macklin, Yang, Yuksel, ACM TOG 44(4):160, 2025; ipc-toolkit `ipc::ogc::TrustRegion::
/// filter_step`) on this framework's detection, XPBD and contact response, and the shared part of
/// `dat` (dat.hpp): a trust region around each vertex's position at the last detection, kept
/// until more than a share γ_e of the movable vertices were truncated. See docs/methods.md.
#include <cstdint>
#include <span>
#include <vector>

#include "ccfr/solvers/detecting_solvers.hpp"

namespace ccfr {

/// Parameters of the trust-region solvers (`contact.ogc.*`, `contact.dat.*`).
struct TrustRegionParams {
  /// γ_p: the share of a pair's free gap d − ξ each side may use; < 1/2 so that two sides moving
  /// toward each other keep ≥ ξ (ipc-toolkit's relaxed_radius_scaling is 2γ_p = 0.9).
  double gamma_p = 0.45;
  /// γ_e: re-detect (and run another outer iteration) once more than this share of the movable
  /// vertices was truncated in a pass (ipc-toolkit's update_threshold).
  double gamma_e = 0.01;
  /// r_q: pairs farther than this at detection give no bound of their own; every vertex moves at
  /// most γ_p (r_q − ξ) per detection. 0: ξ + 2r, the detection range (the largest admissible).
  double query_radius = 0.0;
};

/// Detection, trust-region bookkeeping and re-detection shared by `ogc` and `dat`.
///
/// A detection at the anchors \f$\mathbf{a}\f$ (the pass's start) sets the centres
/// \f$\mathbf{c} = \mathbf{a}\f$ and the solver's per-vertex limits; every later resolve()
/// truncates each movable vertex's displacement \f$\mathbf{x}_v - \mathbf{c}_v\f$ relative to
/// those centres, not to the pass's anchor, until the next detection. A detection runs
/// - in the first outer iteration of every substep (ipc-toolkit's warm_start_time_step),
/// - after a pass that truncated more than γ_e of the movable vertices (OGC's re-detection rule),
/// - when an anchor left its own limits (the loop's analytic-obstacle push or rigid carry moved
///   it) or a vertex became movable that the detection treated as fixed (time.continuation).
///
/// The substep goes on while re-detection is due: resolve() reports the truncated vertices as
/// held back exactly when their share exceeds γ_e, so a pass that truncated at most that share
/// ends the substep with those vertices short of their target (OGC's tolerance).
class TrustRegionSolver : public DetectingSolver {
 public:
  explicit TrustRegionSolver(TrustRegionParams params);
  /// Rejects rigid objects (a per-vertex truncation deforms a rigid body) and a query radius
  /// outside (ξ, ξ + 2r].
  void initialize(const Topology& topo, const SimState& state, const SimulationParams& params) override;
  DetectResult detect(const Positions& anchor, const SimState& state, StepContext& ctx) override;
  SolveResult resolve(Positions& x, const Positions& anchor, const SimState& state, StepContext& ctx) override;
  bool clamps_to_radius() const override { return true; }
  bool guarantees_separation() const override { return true; }
  /// The detected pairs' recount; when re-detection is due, also marks the truncated vertices in
  /// ctx.violated, so that under time.continuation: held_back the next pass frees them (the loop
  /// frees only the vertices held back by r and those of violated pairs).
  std::optional<Index> count_outside(const Positions& x, const Positions& anchor, const SimState& state,
                                     StepContext& ctx) const override;

  const TrustRegionParams& params() const { return params_; }
  /// Positions at the last detection (#V).
  const Positions& centers() const { return centers_; }
  /// The effective query radius r_q (ξ + 2r when the parameter is 0).
  double query_radius() const { return query_radius_; }
  /// γ_p (r_q − ξ): how far any vertex may move from its centre per detection.
  double free_bound() const { return params_.gamma_p * (query_radius_ - offset_); }
  /// Detections run so far (passes that kept the trust region do not count).
  Index detections() const { return detections_; }

 protected:
  /// Builds the per-vertex limits from contacts_ at centers_ (after each detection).
  /// `kinematic` is #V scripted displacements of this pass, or empty.
  virtual void build_limits(std::span<const double> inv_mass, std::span<const Vec3> kinematic) = 0;
  /// Truncates x_v in place to its limits around c_v; returns whether it changed.
  virtual bool truncate(Index v, Vec3& x) const = 0;
  /// Whether p lies within vertex v's limits (with a relative rounding margin).
  virtual bool within(Index v, const Vec3& p) const = 0;

  TrustRegionParams params_;
  Positions centers_;
  double query_radius_ = 0.0, offset_ = 0.0;
  /// debug.audit_tolerance: a pair at least (1 − this) times its offset apart counts as feasible.
  double feasible_tolerance_ = 0.0;

 private:
  bool redetect_ = true;
  Index detections_ = 0;
  std::vector<std::uint8_t> movable_at_detection_;
  std::vector<std::uint8_t> truncated_;  ///< #V: truncated by the last resolve()
  std::vector<std::uint8_t> halted_;     ///< #V: halted during frame `halted_frame_`
  int halted_frame_ = -1;
};

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
