#pragma once
/// @file broad_phase/brute_force.hpp
/// The broad phase `brute_force` (collision/src/broad_phase/brute_force.cpp).
#include <vector>

#include "ccfr/collision/broad_phase.hpp"

namespace ccfr {

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

}  // namespace ccfr
