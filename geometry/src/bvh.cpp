#include "ccfr/geometry/bvh.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"

namespace ccfr {

namespace {

bool has_nan(const AABB& b) { return b.lo.hasNaN() || b.hi.hasNaN(); }

[[noreturn]] void throw_nan(Index i) {
  throw Error("Bvh: box " + std::to_string(i) + " has a NaN coordinate (non-finite positions upstream?)");
}

// Median splits keep the depth below log2(#boxes) + 1, far below this.
constexpr int kMaxStack = 128;

}  // namespace

void Bvh::build(std::span<const AABB> boxes, int leaf_size) {
  leaf_size = std::max(leaf_size, 1);
  num_boxes_ = static_cast<Index>(boxes.size());
  for (Index i = 0; i < num_boxes_; ++i)
    if (has_nan(boxes[i])) throw_nan(i);
  order_.resize(boxes.size());
  for (Index i = 0; i < num_boxes_; ++i) order_[i] = i;
  nodes_.clear();
  leaves_.clear();
  if (num_boxes_ == 0) {
    sorted_.clear();
    return;
  }
  nodes_.reserve(2 * static_cast<size_t>(num_boxes_ / leaf_size + 1));
  build_node(0, num_boxes_, leaf_size, boxes);
  for (Index n = 0; n < static_cast<Index>(nodes_.size()); ++n)
    if (nodes_[n].right < 0) leaves_.push_back(n);
  gather(boxes);
}

Index Bvh::build_node(Index first, Index count, int leaf_size, std::span<const AABB> boxes) {
  const Index id = static_cast<Index>(nodes_.size());
  nodes_.push_back(Node{AABB{}, -1, first, count});
  if (count <= leaf_size) return id;
  // Split at the median centre along the longest axis of the centre bounds. Empty boxes have
  // non-finite centres; they sort to one end, which is harmless.
  AABB cb;
  for (Index k = first; k < first + count; ++k) {
    const Vec3 c = boxes[order_[k]].center();
    if (c.allFinite()) cb.expand(c);
  }
  int axis = 0;
  if (cb.valid()) cb.extent().maxCoeff(&axis);
  const auto begin = order_.begin() + first, end = begin + count, mid = begin + count / 2;
  auto key = [&](Index i) {
    const double k = boxes[i].lo[axis] + boxes[i].hi[axis];
    return std::isnan(k) ? std::numeric_limits<double>::infinity() : k;  // empty box: inf + -inf
  };
  std::nth_element(begin, mid, end, [&](Index a, Index b) {
    const double ka = key(a), kb = key(b);
    return ka < kb || (ka == kb && a < b);  // ties by id: a strict total order, reproducible splits
  });
  build_node(first, count / 2, leaf_size, boxes);
  const Index right = build_node(first + count / 2, count - count / 2, leaf_size, boxes);
  nodes_[id].right = right;
  return id;
}

void Bvh::gather(std::span<const AABB> boxes) {
  sorted_.resize(order_.size());
  for (size_t k = 0; k < order_.size(); ++k) sorted_[k] = boxes[order_[k]];
  // Children follow their parent in depth-first order, so a reverse sweep is bottom-up.
  for (Index n = static_cast<Index>(nodes_.size()) - 1; n >= 0; --n) {
    Node& node = nodes_[n];
    if (node.right < 0) {
      AABB b;
      for (Index k = node.first; k < node.first + node.count; ++k) b.expand(sorted_[k]);
      node.box = b;
    } else {
      node.box = nodes_[n + 1].box;
      node.box.expand(nodes_[node.right].box);
    }
  }
}

void Bvh::refit(std::span<const AABB> boxes) {
  if (static_cast<Index>(boxes.size()) != num_boxes_)
    throw Error("Bvh::refit: " + std::to_string(boxes.size()) + " boxes, the tree was built over " +
                std::to_string(num_boxes_));
  for (Index i = 0; i < num_boxes_; ++i)
    if (has_nan(boxes[i])) throw_nan(i);
  gather(boxes);
}

void Bvh::leaf_pairs(Index leaf, std::vector<std::pair<Index, Index>>& out) const {
  const Node& L = nodes_[leaf];
  const Index lend = L.first + L.count;
  auto emit = [&](Index i, Index j) {
    const Index a = order_[i], b = order_[j];
    out.emplace_back(std::min(a, b), std::max(a, b));
  };
  // Pairs inside the leaf.
  for (Index i = L.first; i < lend; ++i)
    for (Index j = i + 1; j < lend; ++j)
      if (sorted_[i].overlaps(sorted_[j])) emit(i, j);
  // Pairs with leaves after this one in depth-first order: each leaf pair is found exactly once.
  std::array<Index, kMaxStack> stack;
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[stack[--top]];
    if (n.first + n.count <= lend || !n.box.overlaps(L.box)) continue;
    if (n.right >= 0) {
      stack[top++] = n.right;
      stack[top++] = static_cast<Index>(&n - nodes_.data()) + 1;
      continue;
    }
    for (Index i = L.first; i < lend; ++i) {
      const AABB& bi = sorted_[i];
      if (!bi.overlaps(n.box)) continue;
      for (Index j = n.first; j < n.first + n.count; ++j)
        if (bi.overlaps(sorted_[j])) emit(i, j);
    }
  }
}

void Bvh::self_pairs(std::vector<std::pair<Index, Index>>& out) const {
  out.clear();
  const Index num_leaves = static_cast<Index>(leaves_.size());
  if (num_leaves == 0) return;
  const Index chunks = default_chunk_count(num_leaves);
  std::vector<std::vector<std::pair<Index, Index>>> parts(static_cast<size_t>(chunks));
  parallel_chunks(num_leaves, chunks, [&](Index c, Index begin, Index end) {
    auto& part = parts[c];
    part.reserve(static_cast<size_t>(end - begin) * 64);
    for (Index l = begin; l < end; ++l) leaf_pairs(leaves_[l], part);
  });
  std::vector<size_t> offset(parts.size() + 1, 0);
  for (size_t c = 0; c < parts.size(); ++c) offset[c + 1] = offset[c] + parts[c].size();
  out.resize(offset.back());
  parallel_chunks(chunks, chunks, [&](Index c, Index, Index) {
    std::copy(parts[c].begin(), parts[c].end(), out.begin() + static_cast<std::ptrdiff_t>(offset[c]));
  });
}

void Bvh::query(const AABB& box, std::vector<Index>& out) const {
  if (nodes_.empty() || has_nan(box)) return;
  std::array<Index, kMaxStack> stack;
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Index id = stack[--top];
    const Node& n = nodes_[id];
    if (!n.box.overlaps(box)) continue;
    if (n.right >= 0) {
      stack[top++] = n.right;
      stack[top++] = id + 1;
      continue;
    }
    for (Index k = n.first; k < n.first + n.count; ++k)
      if (sorted_[k].overlaps(box)) out.push_back(order_[k]);
  }
}

}  // namespace ccfr
