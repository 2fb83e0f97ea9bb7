#pragma once
/// @file bvh.hpp
/// A flat bounding volume hierarchy over boxes: built, refitted as the boxes move, and queried for
/// all overlapping pairs in parallel. Used by the `bvh` broad phase and the penetration audit.
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry/aabb.hpp"

namespace ccfr {

class Bvh {
 public:
  /// Builds the tree over `boxes` (#B) with at most `leaf_size` boxes per leaf (median split of
  /// the box centres along the longest axis). Throws ccfr::Error if a box has a NaN coordinate;
  /// empty boxes (lo > hi, the default AABB) are allowed and overlap nothing.
  void build(std::span<const AABB> boxes, int leaf_size = 4);
  /// Refits all node bounds to new boxes (same count and order as in build), keeping the tree.
  /// Throws ccfr::Error on a NaN box or a different box count.
  void refit(std::span<const AABB> boxes);
  /// All pairs (i, j), i < j, of overlapping boxes (closed boxes: touching counts), replacing the
  /// contents of `out`. Parallel over fixed chunks of leaves; the output order is deterministic
  /// for given input (independent of thread timing and thread count).
  void self_pairs(std::vector<std::pair<Index, Index>>& out) const;
  /// As above, but pairs of two boxes flagged in `fixed` (#B by original index, or empty for none)
  /// and pairs of two boxes with the same nonzero id in `groups` (#B, or empty for none) are never
  /// enumerated: subtrees holding only flagged boxes are skipped against each other, and so are
  /// subtrees holding only boxes of one group, so a large static mesh or rigid body costs nothing
  /// against itself (only its pairs with other boxes remain). Throws ccfr::Error if a non-empty
  /// `fixed` or `groups` does not hold #B entries.
  /// Not for concurrent calls on one Bvh: both overloads keep their buffers between calls.
  void self_pairs(std::vector<std::pair<Index, Index>>& out, std::span<const std::uint8_t> fixed,
                  std::span<const std::uint32_t> groups = {}) const;
  /// Indices of boxes overlapping `box`, appended to `out` in a deterministic order. A box with a
  /// NaN coordinate overlaps nothing.
  void query(const AABB& box, std::vector<Index>& out) const;
  Index size() const { return num_boxes_; }

 private:
  /// Nodes in depth-first order: an internal node's left child is the next node, so only the
  /// right child is stored. Every node covers the contiguous range [first, first + count) of
  /// order_, which lets self_pairs skip subtrees that lie entirely before the querying leaf.
  struct Node {
    AABB box;
    Index right = -1;            ///< right child, -1 for a leaf
    Index first = 0, count = 0;  ///< range in order_
    Index skip = 0;              ///< the node after this subtree in depth-first order (#nodes after the last)
  };
  void build_node(Index id, Index first, Index count, int leaf_size, const std::vector<Vec3>& centres);
  void gather(std::span<const AABB> boxes);
  /// Calls f(node id, node) for every leaf, in parallel: the bottom-up sweeps' per-box part.
  template <class F>
  void each_leaf(F&& f) const {
    parallel_for(
        static_cast<Index>(leaves_.size()),
        [&](Index b, Index e) {
          for (Index l = b; l < e; ++l) f(leaves_[l], nodes_[leaves_[l]]);
        },
        1024);
  }
  /// Per-box and per-node filters of self_pairs(); each pointer is null when unused.
  struct PairFilter {
    const std::uint8_t* fixed_sorted = nullptr;   ///< #boxes in order_ order: flagged fixed
    const std::uint8_t* live = nullptr;           ///< #nodes: the subtree holds an unflagged box
    const std::uint32_t* group_sorted = nullptr;  ///< #boxes in order_ order: group id
    const std::uint32_t* node_group = nullptr;    ///< #nodes: the one group of the subtree, 0 if mixed
  };
  /// Writes the pairs of `leaf` with itself and the leaves after it to buf[count...], advancing
  /// count (buf grows as needed; entries past count are room, not pairs).
  void leaf_pairs(Index leaf, const PairFilter& f, std::vector<std::pair<Index, Index>>& buf, size_t& count) const;

  std::vector<Node> nodes_;
  std::vector<Index> order_;   ///< #boxes: box ids, leaf-contiguous
  std::vector<AABB> sorted_;   ///< #boxes: boxes in order_ order, for cache-friendly leaf tests
  std::vector<Index> leaves_;  ///< leaf node ids in depth-first order
  // self_pairs() buffers, kept between calls (so one Bvh must not be queried from two threads).
  mutable std::vector<std::vector<std::pair<Index, Index>>> scratch_parts_;
  mutable std::vector<std::uint8_t> scratch_fixed_, scratch_live_;
  mutable std::vector<std::uint32_t> scratch_group_, scratch_node_group_;
  Index num_boxes_ = 0;
};

}  // namespace ccfr
