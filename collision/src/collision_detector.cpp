#include "ccfr/collision/collision_detector.hpp"

#include <algorithm>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/core/timer.hpp"
#include "contact_sink.hpp"
#include "contact_waves.hpp"
#include "initial_proximity.hpp"
#include "region_assembly.hpp"
#include "reuse_list.hpp"
#include "sub_pairs.hpp"

// The orchestrator of the narrow phase's stages: sub-pairs and closest points (sub_pairs.hpp,
// contact_sink.hpp), the initial proximity (initial_proximity.cpp), the kept list
// (reuse_list.cpp) and the region assembly (region_assembly.cpp).
namespace ccfr {

struct CollisionDetector::Stages {
  detail::InitialPairs initial;
  detail::InitialPairs::Mark initial_mark;
  bool marked = false;
  detail::SubPairList list;
  detail::ContactWaves waves;
  detail::AssemblyBuffers assembly;
};

CollisionDetector::CollisionDetector(const Topology& topo, const Positions& initial, ContactModel params,
                                     std::unique_ptr<BroadPhase> broad_phase)
    : topo_(topo),
      params_(params),
      prims_(build_collision_primitives(topo)),
      broad_(std::move(broad_phase)),
      stages_(std::make_unique<Stages>()) {
  if (!broad_) throw Error("CollisionDetector: no broad phase given");
  if (static_cast<Index>(initial.size()) != topo.num_vertices())
    throw Error("CollisionDetector: " + std::to_string(initial.size()) + " initial positions for " +
                std::to_string(topo.num_vertices()) + " vertices");
  if (!(params_.radius > 0.0) || !(params_.offset >= 0.0) || !(params_.repulsion_range >= 0.0))
    throw Error("CollisionDetector: radius must be > 0, offset and repulsion_range >= 0");
  compute_primitive_boxes(prims_, topo_, initial,
                          box_inflation(params_.radius, params_.offset, params_.repulsion_range), boxes_);
  broad_->build(boxes_);
  // The triangles of one rigid body or one obstacle move as a whole and never meet (face_no_self):
  // one group per such object, so the broad phase never enumerates its internal pairs.
  std::vector<std::uint32_t> groups(static_cast<size_t>(prims_.size()), 0);
  for (Index f = 0; f < prims_.num_triangles; ++f)
    if (prims_.face_no_self[f]) groups[f] = static_cast<std::uint32_t>(topo_.face_object[f]) + 1;
  // Without any group the broad phase skips the per-pass group bookkeeping altogether.
  const bool grouped = std::any_of(groups.begin(), groups.end(), [](std::uint32_t g) { return g != 0; });
  broad_->set_groups(grouped ? std::span<const std::uint32_t>(groups) : std::span<const std::uint32_t>{});
  stages_->initial = detail::find_initial_pairs(topo_, prims_, *broad_, initial, params_, candidates_);
}

CollisionDetector::~CollisionDetector() = default;

double separation_lower_bound(const ContactPair& c, const std::vector<Vec3>& x) {
  double scale = 0.0;
  for (int k = 0; k < c.size(); ++k) scale = std::max(scale, x[static_cast<size_t>(c.v[k])].cwiseAbs().sum());
  return separation_lower_bound(c, x, scale);
}

bool CollisionDetector::is_excluded(ContactKind kind, Index a, Index b) const {
  return stages_->initial.table.excluded(kind, a, b);
}
Index CollisionDetector::num_excluded() const { return static_cast<Index>(stages_->initial.table.num_excluded()); }
const InitialProximity& CollisionDetector::initial_proximity() const { return stages_->initial.proximity; }
Index CollisionDetector::num_reduced_active() const { return static_cast<Index>(stages_->initial.active.size()); }
const std::vector<double>& CollisionDetector::reduced_offsets() const { return stages_->initial.reduced_offset; }
double CollisionDetector::pair_offset(ContactKind kind, Index a, Index b) const {
  return stages_->initial.offset(kind, a, b, params_.offset);
}
void CollisionDetector::restore_reduced_offsets(std::span<const double> offsets) {
  stages_->initial.restore(offsets, params_.offset);
  stages_->marked = false;
}

void CollisionDetector::mark_reduced_offsets() {
  stages_->initial.mark(stages_->initial_mark);
  stages_->marked = true;
}
void CollisionDetector::roll_back_reduced_offsets() {
  if (stages_->marked) stages_->initial.roll_back(stages_->initial_mark);
}

void CollisionDetector::set_reuse_skin(double skin) { stages_->list.set_skin(skin); }
double CollisionDetector::reuse_skin() const { return stages_->list.skin(); }
void CollisionDetector::invalidate_reuse() { stages_->list.invalidate(); }
void CollisionDetector::restart_reuse(double recent_step) { stages_->list.restart(recent_step); }
void CollisionDetector::rebuild_broad_phase() {
  rebuild_ = true;
  stages_->list.invalidate();
}

void CollisionDetector::set_record_plane_sources(bool on) { stages_->assembly.record_sources = on; }
std::span<const Index> CollisionDetector::plane_sources() const { return stages_->assembly.plane_sources; }

void CollisionDetector::flag_movable_primitives(std::span<const double> inv_mass) {
  movable_.resize(static_cast<size_t>(prims_.size()));
  fixed_.resize(static_cast<size_t>(prims_.size()));
  parallel_for(
      prims_.size(),
      [&](Index begin, Index end) {
        for (Index p = begin; p < end; ++p) {
          const Index e = prims_.element(p);
          switch (prims_.kind(p)) {
            case PrimitiveKind::triangle:
              movable_[p] =
                  inv_mass[topo_.faces[e][0]] > 0 || inv_mass[topo_.faces[e][1]] > 0 || inv_mass[topo_.faces[e][2]] > 0;
              break;
            case PrimitiveKind::edge:
              movable_[p] = inv_mass[topo_.edges[e][0]] > 0 || inv_mass[topo_.edges[e][1]] > 0;
              break;
            case PrimitiveKind::point:
              movable_[p] = inv_mass[e] > 0;
              break;
          }
          fixed_[p] = !movable_[p];
        }
      },
      4096);
}

void CollisionDetector::run_broad_phase(const Positions& x, bool listing, std::span<const double> vertex_reach) {
  if (!vertex_reach.empty()) {
    // Each box grown by its vertices' largest reach ρ and ξ/2, without the paper's δ/2: two boxes
    // then overlap exactly when their sub-pairs can pass the range ρ_A + ρ_B + ξ the policy checks
    // (a pair between that and ρ_A + ρ_B + ξ + δ was enumerated only to be rejected: 18 % of the
    // soft wires' candidates). The tree is split over the boxes with δ/2, then refitted: a tree
    // split over the tighter boxes would enumerate in another order (their centres round
    // differently), and the contacts' order is part of the trajectory. An adaptive reach never lists.
    if (rebuild_) {
      compute_primitive_boxes(prims_, topo_, x, box_inflation(0.0, params_.offset, params_.repulsion_range), boxes_,
                              vertex_reach);
      broad_->build(boxes_);
      rebuild_ = false;
    }
    compute_primitive_boxes(prims_, topo_, x, box_inflation(0.0, params_.offset, 0.0), boxes_, vertex_reach);
  } else {
    const double inflation = box_inflation(params_.radius, params_.offset, params_.repulsion_range);
    if (rebuild_ && listing) {
      // A tree built over the grown boxes would split differently and enumerate in another order:
      // build it over the boxes of a pass without the list, then refit it to the grown ones.
      compute_primitive_boxes(prims_, topo_, x, inflation, boxes_);
      broad_->build(boxes_);
      rebuild_ = false;
    }
    compute_primitive_boxes(prims_, topo_, x, inflation + (listing ? 0.5 * stages_->list.skin() : 0.0), boxes_);
  }
  if (rebuild_) {
    broad_->build(boxes_);
    rebuild_ = false;
  } else {
    broad_->update(boxes_);
  }
  broad_->set_fixed(fixed_);
  broad_->query_pairs(candidates_);
}

void CollisionDetector::enumerate_candidates(const Positions& x, std::span<const double> inv_mass, bool listing,
                                             std::span<const double> vertex_reach, std::vector<ContactPair>& contacts,
                                             DetectionStats& stats) {
  const Index n = static_cast<Index>(candidates_.size());
  // The usual fixed chunks, finer for a large pass, so that a wave of them (ContactWaves) keeps
  // the threads busy; the contacts come out in candidate order for any chunk count.
  const Index chunks = std::clamp<Index>(n / kCandidatesPerChunk, default_chunk_count(n), kMostCandidateChunks);
  std::vector<DetectionStats> counts(static_cast<size_t>(chunks));
  detail::SubPairList& list = stages_->list;
  // Without listing the old chunks stay allocated but invalid: the next listing pass refills them.
  if (listing) list.resize(chunks);
  stages_->waves.collect(
      chunks,
      [&](Index chunk, std::vector<ContactPair>& out) {
        const Index begin = static_cast<Index>(static_cast<long long>(n) * chunk / chunks);
        const Index end = static_cast<Index>(static_cast<long long>(n) * (chunk + 1) / chunks);
        detail::ContactSink sink{topo_, x, detail::contact_policy(inv_mass, stages_->initial, params_, out)};
        if (!vertex_reach.empty()) sink.policy.vertex_reach = vertex_reach.data();
        if (listing) {
          detail::ContactPolicy& policy = sink.policy;
          list.chunk(chunk).clear();
          policy.list = &list.chunk(chunk);
          policy.list_reach = policy.reach_m + list.skin();
          policy.list_reach_sq = policy.list_reach * policy.list_reach;
        }
        for (Index i = begin; i < end; ++i) {
          const auto [p, q] = candidates_[i];
          if (movable_[p] || movable_[q]) detail::visit_sub_pairs(topo_, prims_, p, q, sink);
        }
        sink.policy.add_to(counts[chunk]);
      },
      contacts);
  for (Index c = 0; c < chunks; ++c) {
    detail::add_counts(stats, counts[c]);
    if (listing) stats.listed += list.size(c);
  }
  if (listing) list.record(topo_, x, inv_mass);
}

void CollisionDetector::detect(const Positions& x, std::span<const double> inv_mass, RegionSet& regions,
                               std::vector<ContactPair>& contacts, DetectionStats& stats,
                               std::span<const Vec3> kinematic_step, std::span<const double> vertex_reach) {
  const Index nv = topo_.num_vertices();
  if (!kinematic_step.empty() && static_cast<Index>(kinematic_step.size()) != nv)
    throw Error("CollisionDetector::detect: kinematic_step has " + std::to_string(kinematic_step.size()) +
                " entries, expected " + std::to_string(nv));
  if (static_cast<Index>(x.size()) != nv || static_cast<Index>(inv_mass.size()) != nv)
    throw Error("CollisionDetector::detect: expected " + std::to_string(nv) + " positions and inverse masses, got " +
                std::to_string(x.size()) + " and " + std::to_string(inv_mass.size()));
  if (!vertex_reach.empty() && static_cast<Index>(vertex_reach.size()) != nv)
    throw Error("CollisionDetector::detect: vertex_reach has " + std::to_string(vertex_reach.size()) +
                " entries, expected " + std::to_string(nv));
  stats = DetectionStats{};
  Stopwatch watch;
  SerialStopwatch serial;
  detail::SubPairList& list = stages_->list;
  // The kept list is built at 2r + ξ + s: an adaptive reach runs the broad phase in every pass.
  const bool keeps_list = list.skin() > 0.0 && vertex_reach.empty();
  const double step = keeps_list ? list.step_since_last_pass(topo_, x) : 0.0;
  stats.reused = keeps_list && list.valid() && list.covers(topo_, x, inv_mass, 2.0 * params_.radius + params_.offset);
  // A listing pass needs the last pass's motion to leave the list valid for two more passes; a
  // pass with per-vertex reaches neither reads nor writes the list (its reach is not the list's).
  const bool listing = vertex_reach.empty() && !stats.reused && list.lists_after(step);
  if (!stats.reused) {
    list.invalidate();
    // Pairs of two immovable primitives are never enumerated (a static obstacle against itself
    // would dominate the broad phase).
    flag_movable_primitives(inv_mass);
    run_broad_phase(x, listing, vertex_reach);
    stats.candidates = static_cast<Index>(candidates_.size());
  }
  stats.broad_s = watch.seconds();
  stats.broad_serial_s = serial.seconds();

  watch.restart();
  serial = SerialStopwatch();
  if (!stages_->initial.active.empty()) stages_->initial.raise(topo_, x, params_.offset);
  if (stats.reused)
    list.evaluate(topo_, x, inv_mass, stages_->initial, params_, stages_->waves, contacts, stats);
  else
    enumerate_candidates(x, inv_mass, listing, vertex_reach, contacts, stats);
  detail::assemble_regions(nv, x, inv_mass, kinematic_step, contacts, stages_->assembly, regions);
  stats.constraints = static_cast<Index>(regions.total());
  stats.narrow_s = watch.seconds();
  stats.narrow_serial_s = serial.seconds();
}

}  // namespace ccfr
