#pragma once
/// @file broad_phase.hpp
/// Broad phase: given one box per collision primitive, report every pair of overlapping boxes.
/// Implementations are interchangeable behind this batch interface and selected by name
/// (`collision.broad_phase` in YAML) through make_broad_phase().
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "ccfr/geometry/aabb.hpp"

namespace ccfr {

using IndexPair = std::pair<Index, Index>;

class BroadPhase {
 public:
  virtual ~BroadPhase() = default;
  /// Registers the primitives' boxes (#P). Called once, or again when the primitive count changes.
  virtual void build(std::span<const AABB> boxes) = 0;
  /// New boxes for the same primitives (same count and order): refit, do not rebuild.
  virtual void update(std::span<const AABB> boxes) = 0;
  /// Every pair (i, j), i < j, whose boxes overlap (closed intervals), appended to `out` after
  /// clearing it. The pair set is exact; the order is deterministic for given input.
  virtual void query_pairs(std::vector<IndexPair>& out) = 0;
  virtual std::string_view name() const = 0;
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

/// Creates the broad phase registered under `name`; throws ccfr::Error listing the valid names.
std::unique_ptr<BroadPhase> make_broad_phase(std::string_view name);
/// Names accepted by make_broad_phase(), in factory-table order.
std::vector<std::string> broad_phase_names();

}  // namespace ccfr
