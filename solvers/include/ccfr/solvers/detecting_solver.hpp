#pragma once
/// @file detecting_solver.hpp
/// DetectingSolver: the detection (CollisionDetector) and contact response (repulsion within δ,
/// friction, contact.momentum) that every contact solver on the CCFR narrow phase shares.
#include <atomic>
#include <memory>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/feasibility/region.hpp"
#include "ccfr/solvers/contact_response.hpp"
#include "ccfr/solvers/contact_solver.hpp"

namespace ccfr {

/// Detection and response shared by every solver that uses the CCFR narrow phase.
class DetectingSolver : public ContactSolver {
 public:
  /// Jacobi sweeps of the inelastic contact (ContactResponse::separate) under contact.momentum.
  static constexpr int kSeparateSweeps = 32;
  /// Rounds of push_through under contact.momentum: how many resting pairs in a row a push from
  /// a fixed or scripted side is passed on through in one pass.
  static constexpr int kPushRounds = 64;
  /// Least room (in units of r) a retreating side must vacate for the pass to be run again for
  /// the side that follows it (split_by_motion).
  static constexpr double kDeferredRoom = 0.01;
  /// How far a substep of gravity presses a resting body into what it rests on, |g| dt²: the
  /// share of every overlap ContactResponse::separate leaves to the planes (resting contact).
  static double rest_overlap(const StepContext& ctx) { return ctx.params.time.gravity.norm() * ctx.dt * ctx.dt; }
  void initialize(const Topology& topo, const SimState& state, const SimulationParams& params) override;
  DetectResult detect(const Positions& anchor, const SimState& state, StepContext& ctx) override;
  void respond(Positions& x, const Positions& anchor, const SimState& state, StepContext& ctx) override;
  /// Detected sub-pairs closer than (1 - debug.audit_tolerance) times their offset at `x`, by their
  /// exact closest points at `x` (not along the detection normal). Sub-pairs not detected were
  /// farther than 2r + ξ at the anchors, and every vertex moved at most r, so they are not closer.
  std::optional<Index> count_outside(const Positions& x, const Positions& anchor, const SimState& state,
                                     StepContext& ctx) const override;
  std::string last_violation() const override { return last_violation_; }
  std::vector<ClosePair> close_pairs(const Positions& x, double keep, size_t max) const override;
  std::optional<bool> region_empty(Index v, const Positions& anchor) const override;
  /// The detector's reduced offsets (initial proximity), the only state kept between substeps.
  std::vector<double> save_state() const override;
  void restore_state(std::span<const double> state) override;
  void mark_substep() override;
  void rewind_substep() override;
  void vertex_diagnostics(std::vector<std::int32_t>& half_spaces, std::vector<double>& distance,
                          std::vector<std::uint8_t>& halted) const override;

  const RegionSet& regions() const { return regions_; }
  const std::vector<ContactPair>& contacts() const { return contacts_; }
  const CollisionDetector& detector() const { return *detector_; }
  const CollisionDetector* collision_detector() const override { return detector_.get(); }
  const std::vector<ContactPair>* detected_contacts() const override { return &contacts_; }

 protected:
  /// Distinct movable vertices of the detected contacts (the paper's collision points).
  Index contact_vertex_count(std::span<const double> inv_mass) const;
  /// Marks this pass's contact vertices (movable, with at least one half-space) for frame `frame`
  /// (the marks restart when the frame changes). Returns {vertices in contact in this pass,
  /// distinct vertices in contact in the frame so far}.
  std::pair<Index, Index> mark_contact_vertices(int frame, std::span<const double> inv_mass);
  /// The inverse masses respond() will pass to the response, for its visibility weights; empty:
  /// weigh every contact.
  virtual std::span<const double> response_mass(const SimState&) { return {}; }

  std::unique_ptr<CollisionDetector> detector_;
  int reuse_frame_ = -1;    ///< frame whose start restarted the detector's kept list
  int rebuild_frame_ = -1;  ///< frame whose first pass rebuilt the broad phase
  RegionSet regions_;

  // dt v and zeros at the frame start (restart_reuse), kept to avoid reallocating per frame.
  Positions reuse_step_, reuse_zero_;
  std::vector<ContactPair> contacts_;
  ContactResponse response_;
  std::vector<double> friction_override_;  ///< #V: material friction of the vertex's object (< 0: global)
  mutable std::string last_violation_;
  mutable std::vector<std::uint8_t> pair_marks_;           ///< #V: vertices of the pairs count_outside() counted
  mutable Index crossing_first_ = 0, crossing_edge_ = -1;  ///< the first crossing counted, for the message
  /// Vertex-face contacts with an edge at their vertex that crosses the face at x but not at
  /// x_start (a primitive swallowed in the substep); marks their vertices like a close pair and
  /// lowers `first` to the lowest such contact. Exact predicates where floating point is unsure.
  Index count_new_crossings(const Positions& x, const Positions& x_start, StepContext& ctx,
                            std::atomic<Index>& first) const;
  Index num_vertices_ = 0;                   ///< #V of the scene (the regions are empty before the first detection)
  std::vector<std::uint8_t> contact_marks_;  ///< #V: in contact during frame `contact_marks_frame_`
  int contact_marks_frame_ = -1;
  Index contact_marks_count_ = 0;  ///< ones in contact_marks_
};

}  // namespace ccfr
