#pragma once
/// @file broad_phase/fcl.hpp
/// The broad phase `fcl` (collision/src/broad_phase/fcl.cpp, the only file that includes FCL).
#include <memory>

#include "ccfr/collision/broad_phase.hpp"

namespace ccfr {

/// FCL's DynamicAABBTreeCollisionManager, the AABB tree of the paper's implementation. Objects are
/// registered once; update() writes the new boxes into them and refits the tree (FCL's `update()`
/// without arguments); query_pairs() runs FCL's self-collide. The objects of each nonzero group
/// (set_groups) live in a tree of their own that is only collided against the other trees, so a
/// group's internal pairs are never enumerated. Single-threaded. FCL stays private
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

}  // namespace ccfr
