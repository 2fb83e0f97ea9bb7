#pragma once
/// @file reuse_list.hpp
/// Narrow-phase stage 3 (private): the kept sub-pair list (CollisionDetector::set_reuse_skin), a
/// Verlet list at the level of sub-pairs. A listing pass records every sub-pair within 2r + ξ + s
/// (s = skin, m) that is not excluded and has a movable vertex; later passes evaluate only those
/// while the motion since listing cannot have brought another into the range 2r + ξ.
#include <cstdint>
#include <span>
#include <vector>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/geometry/aabb.hpp"
#include "contact_waves.hpp"
#include "initial_proximity.hpp"

namespace ccfr::detail {

/// One listed sub-pair: what a later pass needs to evaluate it without the broad phase, the
/// enumeration or the exclusion look-up.
struct ListedSubPair {
  Index a = 0, b = 0;  ///< canonical ids (see sub_pair_key)
  Index slot = -2;     ///< reduced-offset slot, negative (InitialPairTable::kAbsent) for ξ
  ContactKind kind = ContactKind::vf;
  float distance = 0.0f;  ///< distance when listed (m), rounded down: a lower bound
  static ListedSubPair make(ContactKind kind, Index a, Index b, Index slot, double dist_sq);
};

/// The list, its listing positions and the decisions of when to list and when it still covers.
class SubPairList {
 public:
  /// Throws ccfr::Error unless 0 <= skin < infinity; drops the list (and its memory at 0).
  void set_skin(double skin);
  double skin() const { return skin_; }
  bool valid() const { return valid_; }
  void invalidate() { valid_ = false; }
  /// Drops the list and the previous positions; `recent_step` (m, ignored unless finite and >= 0)
  /// stands for the motion since the last pass at the next one.
  void restart(double recent_step);
  /// The spread (ReuseMotion) of x − the previous pass's positions: restart()'s step if one is
  /// pending, infinity without a previous pass or on NaN; then remembers x.
  double step_since_last_pass(const Topology& topo, const Positions& x);
  /// Whether a pass whose previous step was `step` lists: when that step, repeated twice, keeps
  /// the list valid (4 step < s), so that it can be expected to serve at least twice.
  bool lists_after(double step) const { return skin_ > 0.0 && 4.0 * step < skin_; }
  /// Whether the list still covers every sub-pair within `reach` (2r + ξ, m) at x, the movable
  /// flags unchanged; stores the per-vertex displacements evaluate() uses.
  bool covers(const Topology& topo, const Positions& x, std::span<const double> inv_mass, double reach);
  /// Chunk storage of a listing pass, cleared; one chunk per candidate chunk, in enumeration order.
  std::vector<ListedSubPair>& chunk(Index c) { return chunks_[static_cast<size_t>(c)]; }
  void resize(Index chunks) { chunks_.resize(static_cast<size_t>(chunks)); }
  Index size(Index c) const { return static_cast<Index>(chunks_[static_cast<size_t>(c)].size()); }
  /// Ends a listing pass: records the positions, the objects' boxes and the movable flags.
  void record(const Topology& topo, const Positions& x, std::span<const double> inv_mass);
  /// A pass over the list (covers() true just before): into `contacts`, in list order, the
  /// contacts of every listed sub-pair whose distance bound (listed distance less both sides'
  /// displacement) does not clear the range; adds the counters to `stats`.
  void evaluate(const Topology& topo, const Positions& x, std::span<const double> inv_mass, const InitialPairs& initial,
                const ContactModel& params, ContactWaves& waves, std::vector<ContactPair>& contacts,
                DetectionStats& stats) const;

 private:
  double skin_ = 0.0;
  bool valid_ = false;
  std::vector<std::vector<ListedSubPair>> chunks_;  ///< per chunk, in enumeration order
  Positions list_x_;
  Positions last_x_;                        ///< positions of the previous pass (skin > 0 only)
  double restart_step_ = -1.0;              ///< restart()'s step for the next pass (< 0: none)
  std::vector<std::uint8_t> list_movable_;  ///< per vertex
  std::vector<double> disp_;                ///< per vertex: |x − list_x_ − t| of the current pass (m)
  std::vector<AABB> list_boxes_;            ///< per object: box of its vertices at listing
};

}  // namespace ccfr::detail
