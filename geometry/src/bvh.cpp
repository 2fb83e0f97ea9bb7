#include "ccfr/geometry/bvh.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include "ccfr/core/buffers.hpp"
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

namespace {

// Nodes of the subtree over `count` boxes: median splits make the shape a function of the count
// alone, so subtrees can be laid out (and built in parallel) before they exist.
Index subtree_nodes(Index count, int leaf_size) {
  if (count <= leaf_size) return 1;
  return 1 + subtree_nodes(count / 2, leaf_size) + subtree_nodes(count - count / 2, leaf_size);
}

// Subtrees at least this large are split across tasks.
constexpr Index kParallelBuild = 8192;

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
  // Centres once, contiguous; an empty box (inf + -inf) gets +inf so every key stays ordered.
  std::vector<Vec3> centres(boxes.size());
  parallel_for(num_boxes_, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) {
      const Vec3 c = boxes[i].lo + boxes[i].hi;
      centres[i] = c.hasNaN() ? Vec3::Constant(std::numeric_limits<double>::infinity()) : c;
    }
  });
  nodes_.resize(static_cast<size_t>(subtree_nodes(num_boxes_, leaf_size)));
  build_node(0, 0, num_boxes_, leaf_size, centres);
  for (Index n = 0; n < static_cast<Index>(nodes_.size()); ++n)
    if (nodes_[n].right < 0) leaves_.push_back(n);
  gather(boxes);
}

void Bvh::build_node(Index id, Index first, Index count, int leaf_size, const std::vector<Vec3>& centres) {
  nodes_[id] = Node{AABB{}, -1, first, count, id + subtree_nodes(count, leaf_size)};
  if (count <= leaf_size) return;
  // Split at the median centre along the longest axis of the (finite) centre bounds.
  AABB cb;
  for (Index k = first; k < first + count; ++k)
    if (centres[order_[k]].allFinite()) cb.expand(centres[order_[k]]);
  int axis = 0;
  if (cb.valid()) cb.extent().maxCoeff(&axis);
  const auto begin = order_.begin() + first, end = begin + count, mid = begin + count / 2;
  std::nth_element(begin, mid, end, [&](Index a, Index b) {
    const double ka = centres[a][axis], kb = centres[b][axis];
    return ka < kb || (ka == kb && a < b);  // ties by id: a strict total order, reproducible splits
  });
  const Index left = id + 1, right = id + 1 + subtree_nodes(count / 2, leaf_size);
  nodes_[id].right = right;
  auto build_left = [&] { build_node(left, first, count / 2, leaf_size, centres); };
  auto build_right = [&] { build_node(right, first + count / 2, count - count / 2, leaf_size, centres); };
  if (count >= kParallelBuild) {
    parallel_invoke(build_left, build_right);
  } else {
    build_left();
    build_right();
  }
}

void Bvh::gather(std::span<const AABB> boxes) {
  // Every pass refits the tree: the NaN check, the copy in tree order and the leaves run in
  // parallel chunks (a serial refit of the 50 layers' 1.2 M boxes cost about 0.3 s a frame of
  // serial work). The lowest NaN index is reported whatever the chunking, before anything changes.
  const Index nb = static_cast<Index>(order_.size());
  const Index chunks = default_chunk_count(nb);
  std::vector<Index> first_nan(static_cast<size_t>(chunks), nb);
  parallel_chunks(nb, chunks, [&](Index c, Index b, Index e) {
    for (Index i = b; i < e && first_nan[c] == nb; ++i)
      if (has_nan(boxes[i])) first_nan[c] = i;
  });
  if (const Index i = *std::min_element(first_nan.begin(), first_nan.end()); i < nb) throw_nan(i);
  sorted_.resize(order_.size());
  parallel_for(nb, [&](Index b, Index e) {
    for (Index k = b; k < e; ++k) sorted_[k] = boxes[order_[k]];
  });
  each_leaf([&](Index n, const Node& node) {
    AABB box;
    for (Index k = node.first; k < node.first + node.count; ++k) box.expand(sorted_[k]);
    nodes_[n].box = box;
  });
  // Children follow their parent in depth-first order, so a reverse sweep is bottom-up; the
  // internal nodes, as many as the leaves, take two reads each.
  for (Index n = static_cast<Index>(nodes_.size()) - 1; n >= 0; --n) {
    Node& node = nodes_[n];
    if (node.right < 0) continue;
    node.box = nodes_[n + 1].box;
    node.box.expand(nodes_[node.right].box);
  }
}

void Bvh::refit(std::span<const AABB> boxes) {
  if (static_cast<Index>(boxes.size()) != num_boxes_)
    throw Error("Bvh::refit: " + std::to_string(boxes.size()) + " boxes, the tree was built over " +
                std::to_string(num_boxes_));
  gather(boxes);
}

void Bvh::leaf_pairs(Index leaf, const PairFilter& f, std::vector<std::pair<Index, Index>>& buf, size_t& count) const {
  const Node& L = nodes_[leaf];
  const Index lend = L.first + L.count;
  auto excluded = [&](Index i, Index j) {
    return (f.fixed_sorted && f.fixed_sorted[i] && f.fixed_sorted[j]) ||
           (f.group_sorted && f.group_sorted[i] != 0 && f.group_sorted[i] == f.group_sorted[j]);
  };
  // Every tested pair is written at buf[count] and kept by advancing count: whether two boxes
  // overlap follows no pattern a branch predictor learns, and a branch per test mispredicted
  // often. Room for a visit's at most L.count x n.count pairs is made before it.
  auto room = [&](Index pairs) {
    const size_t need = count + static_cast<size_t>(pairs);
    if (buf.size() < need) buf.resize(std::max(2 * buf.size(), need));
  };
  auto put = [&](Index i, Index j, bool keep) {
    const Index a = order_[i], b = order_[j];
    buf[count] = {std::min(a, b), std::max(a, b)};
    count += keep;
  };
  // A leaf of flagged boxes only looks at subtrees that hold an unflagged one; a leaf of one group
  // skips the subtrees of that same group.
  const bool leaf_live = !f.live || f.live[leaf];
  const std::uint32_t leaf_group = f.node_group ? f.node_group[leaf] : 0;
  auto skipped = [&](Index id) {
    return (!leaf_live && !f.live[id]) || (leaf_group != 0 && f.node_group[id] == leaf_group);
  };
  // Pairs inside the leaf.
  if (leaf_live && leaf_group == 0) {
    room(L.count * L.count);
    for (Index i = L.first; i < lend; ++i)
      for (Index j = i + 1; j < lend; ++j) put(i, j, sorted_[i].overlaps(sorted_[j]) & !excluded(i, j));
  }
  // Pairs with leaves after this one in depth-first order: each leaf pair is found exactly once.
  // Those nodes are exactly the ones after the leaf in the array, so a forward scan that jumps over
  // a non-overlapping subtree visits them in the same order as a descent from the root, without
  // passing through the leaf's ancestors again or keeping a stack.
  const Index num_nodes = static_cast<Index>(nodes_.size());
  for (Index id = leaf + 1; id < num_nodes;) {
    const Node& n = nodes_[id];
    if (skipped(id) || !n.box.overlaps(L.box)) {
      id = n.skip;
      continue;
    }
    ++id;
    if (n.right >= 0) continue;
    room(L.count * n.count);
    for (Index i = L.first; i < lend; ++i) {
      const AABB& bi = sorted_[i];
      if (!bi.overlaps(n.box)) continue;
      for (Index j = n.first; j < n.first + n.count; ++j) put(i, j, bi.overlaps(sorted_[j]) & !excluded(i, j));
    }
  }
}

void Bvh::self_pairs(std::vector<std::pair<Index, Index>>& out) const { self_pairs(out, {}, {}); }

void Bvh::self_pairs(std::vector<std::pair<Index, Index>>& out, std::span<const std::uint8_t> fixed,
                     std::span<const std::uint32_t> groups) const {
  if (!fixed.empty() && static_cast<Index>(fixed.size()) != num_boxes_)
    throw Error("Bvh::self_pairs: " + std::to_string(fixed.size()) + " fixed flags, the tree holds " +
                std::to_string(num_boxes_) + " boxes");
  if (!groups.empty() && static_cast<Index>(groups.size()) != num_boxes_)
    throw Error("Bvh::self_pairs: " + std::to_string(groups.size()) + " group ids, the tree holds " +
                std::to_string(num_boxes_) + " boxes");
  const Index num_leaves = static_cast<Index>(leaves_.size());
  if (num_leaves == 0) {
    out.clear();
    return;
  }
  const Index num_nodes = static_cast<Index>(nodes_.size());
  PairFilter filter;
  // Kept between calls: fresh blocks of this size every pass were faulted in again each time.
  // Children follow their parent in depth-first order, so the reverse sweeps below are bottom-up.
  if (!fixed.empty()) {
    std::vector<std::uint8_t>& fixed_sorted = scratch_fixed_;
    std::vector<std::uint8_t>& live = scratch_live_;
    fixed_sorted.resize(order_.size());
    live.resize(nodes_.size());
    parallel_for(num_boxes_, [&](Index b, Index e) {
      for (Index k = b; k < e; ++k) fixed_sorted[k] = fixed[order_[k]] != 0;
    });
    each_leaf([&](Index n, const Node& node) {
      std::uint8_t any = 0;
      for (Index k = node.first; k < node.first + node.count; ++k) any |= !fixed_sorted[k];
      live[n] = any;
    });
    for (Index n = num_nodes - 1; n >= 0; --n)
      if (nodes_[n].right >= 0) live[n] = live[n + 1] | live[nodes_[n].right];
    filter.fixed_sorted = fixed_sorted.data();
    filter.live = live.data();
  }
  if (!groups.empty()) {
    std::vector<std::uint32_t>& group_sorted = scratch_group_;
    std::vector<std::uint32_t>& node_group = scratch_node_group_;
    group_sorted.resize(order_.size());
    node_group.resize(nodes_.size());
    parallel_for(num_boxes_, [&](Index b, Index e) {
      for (Index k = b; k < e; ++k) group_sorted[k] = groups[order_[k]];
    });
    each_leaf([&](Index n, const Node& node) {
      std::uint32_t g = group_sorted[node.first];
      for (Index k = node.first + 1; k < node.first + node.count; ++k)
        if (group_sorted[k] != g) g = 0;
      node_group[n] = g;
    });
    for (Index n = num_nodes - 1; n >= 0; --n) {
      const Node& node = nodes_[n];
      if (node.right < 0) continue;
      const std::uint32_t g = node_group[n + 1];
      node_group[n] = g == node_group[node.right] ? g : 0;
    }
    filter.group_sorted = group_sorted.data();
    filter.node_group = node_group.data();
  }
  const Index chunks = default_chunk_count(num_leaves);
  // Per chunk its pairs, the first counts[c] of parts[c] (the rest is room, kept between calls).
  std::vector<std::vector<std::pair<Index, Index>>>& parts = scratch_parts_;
  parts.resize(static_cast<size_t>(chunks));
  std::vector<size_t> counts(static_cast<size_t>(chunks), 0);
  parallel_chunks(num_leaves, chunks, [&](Index c, Index begin, Index end) {
    auto& part = parts[c];
    if (part.size() < static_cast<size_t>(end - begin) * 64) part.resize(static_cast<size_t>(end - begin) * 64);
    for (Index l = begin; l < end; ++l) leaf_pairs(leaves_[l], filter, part, counts[c]);
  });
  std::vector<size_t> offset(parts.size() + 1, 0);
  for (size_t c = 0; c < parts.size(); ++c) offset[c + 1] = offset[c] + counts[c];
  resize_for_overwrite(out, offset.back());  // every pair is copied in below
  parallel_chunks(chunks, chunks, [&](Index c, Index, Index) {
    std::copy_n(parts[c].begin(), counts[c], out.begin() + static_cast<std::ptrdiff_t>(offset[c]));
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
