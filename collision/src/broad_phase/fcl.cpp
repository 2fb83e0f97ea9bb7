// The broad phase `fcl`: FCL's dynamic AABB tree, the tree of the paper's implementation. The only
// translation unit that includes FCL (a PRIVATE dependency). One file per built-in broad phase, named
// by its key (docs/extending.md, "A broad phase: one file").
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/sphere.h>

#include <algorithm>

#include "../builtin_broad_phases.hpp"
#include "ccfr/collision/broad_phase/fcl.hpp"
#include "ccfr/core/error.hpp"

namespace ccfr {

namespace {

/// A collision object whose world box is written directly. FCL would otherwise derive the box
/// from a geometry and a transform (computeAABB), which is both slower and unable to represent
/// a deforming triangle; all objects share one dummy geometry that FCL never queries because
/// only the broad phase runs.
class BoxObject final : public fcl::CollisionObjectd {
 public:
  BoxObject(const std::shared_ptr<fcl::CollisionGeometryd>& dummy, Index id) : fcl::CollisionObjectd(dummy) {
    setUserData(reinterpret_cast<void*>(static_cast<std::intptr_t>(id)));
  }
  void set_box(const AABB& b) {
    aabb.min_ = b.lo;
    aabb.max_ = b.hi;
  }
  Index id() const { return static_cast<Index>(reinterpret_cast<std::intptr_t>(getUserData())); }
};

struct CollideData {
  const std::vector<AABB>* boxes;
  const std::vector<std::uint8_t>* fixed;  ///< empty: nothing fixed
  std::vector<IndexPair>* out;
};

// FCL reports pairs whose tree boxes overlap; the explicit re-check keeps the pair set exactly
// the closed-interval overlap set the other broad phases report.
bool collect_pair(fcl::CollisionObjectd* o1, fcl::CollisionObjectd* o2, void* data) {
  auto& d = *static_cast<CollideData*>(data);
  Index a = static_cast<const BoxObject*>(o1)->id(), b = static_cast<const BoxObject*>(o2)->id();
  if (a > b) std::swap(a, b);
  // FCL's tree cannot prune fixed-fixed subtrees; such pairs are dropped here (the bvh skips them).
  if (!d.fixed->empty() && (*d.fixed)[a] && (*d.fixed)[b]) return false;
  if ((*d.boxes)[a].overlaps((*d.boxes)[b])) d.out->emplace_back(a, b);
  return false;  // never stop early: we want every pair
}

using Manager = fcl::DynamicAABBTreeCollisionManagerd;

}  // namespace

struct FclBroadPhase::Impl {
  std::shared_ptr<fcl::CollisionGeometryd> dummy = std::make_shared<fcl::Sphered>(0.0);
  std::vector<std::unique_ptr<BoxObject>> objects;
  std::vector<AABB> boxes;
  /// managers[0]: the objects of no group, self-collided; then one tree per nonzero group, only
  /// collided against the other trees, so no pair inside a group is ever enumerated.
  std::vector<std::unique_ptr<Manager>> managers;
  std::uint64_t groups_version = 0;  ///< the set_groups() call the partition was made for
  bool stale = false;                ///< partitioned without the groups (they did not fit the boxes)
  bool built = false;

  void partition(std::span<const std::uint32_t> groups) {
    managers.clear();
    std::vector<std::vector<fcl::CollisionObjectd*>> members(1);
    std::vector<std::pair<std::uint32_t, Index>> keyed;  // (group, object) of grouped objects
    for (size_t i = 0; i < objects.size(); ++i) {
      if (groups.empty() || groups[i] == 0)
        members[0].push_back(objects[i].get());
      else
        keyed.emplace_back(groups[i], static_cast<Index>(i));
    }
    std::sort(keyed.begin(), keyed.end());
    for (size_t k = 0; k < keyed.size(); ++k) {
      if (k == 0 || keyed[k].first != keyed[k - 1].first) members.emplace_back();
      members.back().push_back(objects[static_cast<size_t>(keyed[k].second)].get());
    }
    for (auto& m : members) {
      managers.push_back(std::make_unique<Manager>());
      managers.back()->registerObjects(m);
      managers.back()->setup();
    }
  }
};

FclBroadPhase::FclBroadPhase() : impl_(std::make_unique<Impl>()) {}
FclBroadPhase::~FclBroadPhase() = default;

void FclBroadPhase::build(std::span<const AABB> boxes) {
  check_finite_boxes(boxes, name());
  Impl& m = *impl_;
  m.boxes.assign(boxes.begin(), boxes.end());
  m.objects.clear();
  m.objects.reserve(boxes.size());
  for (size_t i = 0; i < boxes.size(); ++i) {
    m.objects.push_back(std::make_unique<BoxObject>(m.dummy, static_cast<Index>(i)));
    m.objects.back()->set_box(boxes[i]);
  }
  m.built = true;
  // Partitioned by the current groups if they fit the boxes; else query_pairs() rejects them.
  const bool fits = groups_.empty() || groups_.size() == boxes.size();
  m.partition(fits ? std::span<const std::uint32_t>(groups_) : std::span<const std::uint32_t>{});
  m.groups_version = groups_version_;
  m.stale = !fits;
}

void FclBroadPhase::update(std::span<const AABB> boxes) {
  Impl& m = *impl_;
  if (!m.built || boxes.size() != m.objects.size())
    throw Error("fcl broad phase: update() with a different box count than build()");
  check_finite_boxes(boxes, name());
  m.boxes.assign(boxes.begin(), boxes.end());
  for (size_t i = 0; i < boxes.size(); ++i) m.objects[i]->set_box(boxes[i]);
  // The no-argument update copies every object's box into its leaf and refits the tree once;
  // update(objects) re-inserts leaf by leaf, ~10x slower and keeping stale, larger boxes.
  for (auto& tree : m.managers) tree->update();
}

void FclBroadPhase::query_pairs(std::vector<IndexPair>& out) {
  out.clear();
  Impl& m = *impl_;
  if (!m.built) return;
  check_fixed_count(m.boxes.size());
  if (m.stale || m.groups_version != groups_version_) {
    m.partition(groups_);
    m.groups_version = groups_version_;
    m.stale = false;
  }
  CollideData data{&m.boxes, &fixed_, &out};
  m.managers[0]->collide(&data, collect_pair);
  for (size_t i = 0; i < m.managers.size(); ++i)
    for (size_t j = i + 1; j < m.managers.size(); ++j) m.managers[i]->collide(m.managers[j].get(), &data, collect_pair);
  // FCL's traversal order follows its tree, whose rebalancing depends on every earlier update: in
  // pair order, a run resumed from a checkpoint (a fresh tree) gives the same contacts as one that
  // never stopped.
  std::sort(out.begin(), out.end());
}

void register_broad_phase_fcl(BroadPhaseRegistry& registry) {
  registry.add({"fcl", "FCL's dynamic AABB tree (single-threaded)", {}, [](const ParamValues&) {
                  return std::make_unique<FclBroadPhase>();
                }});
}

}  // namespace ccfr
