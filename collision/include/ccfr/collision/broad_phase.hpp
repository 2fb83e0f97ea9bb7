#pragma once
/// @file broad_phase.hpp
/// Broad phase: given one box per collision primitive, report every pair of overlapping boxes.
/// Implementations are interchangeable behind this batch interface and selected by name
/// (`collision.broad_phase` in YAML) through the registry broad_phases(). Adding one is one new
/// file, collision/src/broad_phase/<key>.cpp (docs/extending.md).
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "ccfr/core/registry.hpp"
#include "ccfr/geometry/aabb.hpp"

namespace ccfr {

using IndexPair = std::pair<Index, Index>;

class BroadPhase {
 public:
  virtual ~BroadPhase() = default;
  /// Registers the primitives' boxes (#P). Called once, or again when the primitive count changes.
  /// Throws ccfr::Error if a box is not finite (NaN positions upstream).
  virtual void build(std::span<const AABB> boxes) = 0;
  /// New boxes for the same primitives (same count and order): refit, do not rebuild.
  /// Throws ccfr::Error if a box is not finite or the count differs from build().
  virtual void update(std::span<const AABB> boxes) = 0;
  /// Every pair (i, j), i < j, whose boxes overlap (closed intervals), that are not both fixed
  /// (set_fixed) and not of one nonzero group (set_groups), appended to `out` after clearing it.
  /// The pair set is exact; the order is deterministic for given input. Throws ccfr::Error if the
  /// fixed flags or the group ids do not match the boxes in count.
  virtual void query_pairs(std::vector<IndexPair>& out) = 0;
  virtual std::string_view name() const = 0;

  /// Flags primitives that cannot move this pass (#P, or empty: none), kept until the next call. A
  /// pair of two fixed primitives can never change, so query_pairs() never reports it: a static
  /// obstacle is never paired with another obstacle, and under held-back continuation the
  /// primitives a pass does not move are not paired with each other.
  void set_fixed(std::span<const std::uint8_t> fixed) { fixed_.assign(fixed.begin(), fixed.end()); }
  /// Group id of every primitive (#P, or empty: none), kept until the next call; 0 is no group. A
  /// pair of two primitives with the same nonzero id is never reported: the triangles of one rigid
  /// body or one obstacle move as a whole and never meet. Composes with set_fixed(): a pair is
  /// dropped when either rule drops it. The bvh and fcl broad phases prune whole subtrees of one
  /// group, so a large rigid mesh costs nothing against itself.
  void set_groups(std::span<const std::uint32_t> groups) {
    groups_.assign(groups.begin(), groups.end());
    ++groups_version_;
  }

 protected:
  bool both_fixed(Index a, Index b) const { return !fixed_.empty() && fixed_[a] && fixed_[b]; }
  bool same_group(Index a, Index b) const { return !groups_.empty() && groups_[a] != 0 && groups_[a] == groups_[b]; }
  /// Whether query_pairs() must drop the pair (a, b).
  bool excluded(Index a, Index b) const { return both_fixed(a, b) || same_group(a, b); }
  /// Throws ccfr::Error if the fixed flags or group ids are set for another box count.
  void check_fixed_count(size_t num_boxes) const;
  std::vector<std::uint8_t> fixed_;
  std::vector<std::uint32_t> groups_;
  std::uint64_t groups_version_ = 0;  ///< bumped by set_groups(), for trees that partition by group
};

/// Throws ccfr::Error naming `who` and the first box whose bounds are not finite. Every broad
/// phase calls it before touching its tree (FCL's tree crashes on NaN boxes).
void check_finite_boxes(std::span<const AABB> boxes, std::string_view who);

/// The registry of broad phases: bvh, fcl, brute_force, then whatever downstream code adds.
using BroadPhaseRegistry = Registry<BroadPhase>;
BroadPhaseRegistry& broad_phases();
/// Creates the broad phase registered under `name` with `params` (defaults for the rest); throws
/// ccfr::Error listing the valid names.
std::unique_ptr<BroadPhase> make_broad_phase(std::string_view name, const ParamValues& params = {});
/// Registered names, in registration order.
std::vector<std::string> broad_phase_names();
/// The broad phase used when none is configured: the fastest measured one ("bvh").
std::string_view default_broad_phase_name();

}  // namespace ccfr
