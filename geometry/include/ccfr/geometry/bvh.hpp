#pragma once
/// @file bvh.hpp
/// A flat bounding volume hierarchy over boxes: built once, refitted each pass, and queried for
/// all overlapping pairs in parallel. Used by the `bvh` broad phase and the penetration audit.
#include <span>
#include <utility>
#include <vector>

#include "ccfr/geometry/aabb.hpp"

namespace ccfr {

class Bvh {
 public:
  /// Builds the tree over `boxes` with at most `leaf_size` boxes per leaf.
  void build(std::span<const AABB> boxes, int leaf_size = 4);
  /// Refits all node bounds to new boxes (same count and order as in build), keeping the tree.
  void refit(std::span<const AABB> boxes);
  /// All pairs (i, j), i < j, of overlapping boxes. Parallel; the output order is
  /// deterministic for given input (independent of thread timing).
  void self_pairs(std::vector<std::pair<Index, Index>>& out) const;
  /// Indices of boxes overlapping `box`, appended to `out`.
  void query(const AABB& box, std::vector<Index>& out) const;
  Index size() const { return num_boxes_; }

 private:
  struct Node {
    AABB box;
    Index left = -1, right = -1;  ///< children, -1 for a leaf
    Index first = 0, count = 0;   ///< leaf: range in order_
  };
  std::vector<Node> nodes_;
  std::vector<Index> order_;  ///< box ids, leaf-contiguous
  Index num_boxes_ = 0;
};

}  // namespace ccfr
