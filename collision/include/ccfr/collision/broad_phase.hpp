#pragma once
/// @file broad_phase.hpp
/// Broad phase: given one box per collision primitive, report every pair of overlapping boxes.
/// Implementations are interchangeable behind this batch interface and selected by name
/// (`collision.broad_phase` in YAML) through the registry broad_phases(). Adding one is one new
/// source file and its registration (docs/extending.md).
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "ccfr/core/registry.hpp"
#include "ccfr/geometry/aabb.hpp"
#include "ccfr/geometry/bvh.hpp"

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
  /// Every pair (i, j), i < j, whose boxes overlap (closed intervals) and that are not both
  /// fixed (set_fixed), appended to `out` after clearing it. The pair set is exact; the order is
  /// deterministic for given input. Throws ccfr::Error if the fixed flags do not match the boxes.
  virtual void query_pairs(std::vector<IndexPair>& out) = 0;
  virtual std::string_view name() const = 0;

  /// Flags primitives that cannot move (#P, or empty: none), kept until the next call. A pair of
  /// two fixed primitives can never change, so query_pairs() never reports it: a static obstacle
  /// is never paired with itself or another obstacle (the bvh does not even enumerate such pairs).
  void set_fixed(std::span<const std::uint8_t> fixed) { fixed_.assign(fixed.begin(), fixed.end()); }

 protected:
  bool both_fixed(Index a, Index b) const { return !fixed_.empty() && fixed_[a] && fixed_[b]; }
  void check_fixed_count(size_t num_boxes) const;
  std::vector<std::uint8_t> fixed_;
};

/// O(P²) reference: tests every pair. For tests and tiny scenes only.
class BruteForceBroadPhase final : public BroadPhase {
 public:
  void build(std::span<const AABB> boxes) override;
  void update(std::span<const AABB> boxes) override;
  void query_pairs(std::vector<IndexPair>& out) override;
  std::string_view name() const override { return "brute_force"; }

 private:
  std::vector<AABB> boxes_;
};

/// The flat BVH of ccfr::geometry (at most 4 boxes per leaf): built once, refitted by update(),
/// self-queried in parallel. About 5x faster than FCL's tree on 2 cores (docs/perf/collision.md).
class BvhBroadPhase final : public BroadPhase {
 public:
  void build(std::span<const AABB> boxes) override;
  void update(std::span<const AABB> boxes) override;
  void query_pairs(std::vector<IndexPair>& out) override;
  std::string_view name() const override { return "bvh"; }

 private:
  Bvh bvh_;
};

/// FCL's DynamicAABBTreeCollisionManager, the AABB tree of the paper's implementation. Objects are
/// registered once; update() writes the new boxes into them and refits the tree (FCL's `update()`
/// without arguments); query_pairs() runs FCL's self-collide. Single-threaded. FCL stays private
/// to fcl_broad_phase.cpp, hence the opaque implementation.
class FclBroadPhase final : public BroadPhase {
 public:
  FclBroadPhase();
  ~FclBroadPhase() override;
  FclBroadPhase(const FclBroadPhase&) = delete;
  FclBroadPhase& operator=(const FclBroadPhase&) = delete;

  void build(std::span<const AABB> boxes) override;
  void update(std::span<const AABB> boxes) override;
  void query_pairs(std::vector<IndexPair>& out) override;
  std::string_view name() const override { return "fcl"; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
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
