#pragma once
/// @file trust_region_solver.hpp
/// TrustRegionSolver: the detection, per-vertex trust regions and re-detection rule that `ogc`
/// (ogc.hpp) and `dat` (dat.hpp) share, with their parameters (TrustRegionParams).
#include <cstdint>
#include <span>
#include <vector>

#include "ccfr/solvers/detecting_solver.hpp"

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

}  // namespace ccfr
