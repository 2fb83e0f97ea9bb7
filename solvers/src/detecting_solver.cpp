// The detection every region-based and trust-region solver shares: CCFR's per-vertex regions and
// the contacts of the current positions, rebuilt each pass (docs/collision.md), plus the contact
// response and the counts the loop and the audit read.
#include "ccfr/solvers/detecting_solver.hpp"

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/feasibility/projector.hpp"
#include "ccfr/geometry/distance.hpp"
#include "ccfr/geometry_exact/predicates.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <tuple>

namespace ccfr {

void DetectingSolver::initialize(const Topology& topo, const SimState& state, const SimulationParams& params) {
  detector_ = std::make_unique<CollisionDetector>(
      topo, state.x, params.contact,
      make_broad_phase(params.collision.broad_phase, params.collision.broad_phase_params));
  detector_->set_reuse_skin(params.collision.reuse_skin * params.contact.radius);
  // The response reads the contacts per vertex in the order the region assembly already built.
  detector_->set_record_plane_sources(true);
  regions_.clear(topo.num_vertices());
  num_vertices_ = topo.num_vertices();
  friction_override_.assign(static_cast<size_t>(topo.num_vertices()), -1.0);
  bool any = false;
  for (size_t o = 0; o < topo.objects.size(); ++o) {
    const double mu = params.objects[o].material.friction;
    if (mu < 0.0) continue;
    any = true;
    for (Index v = topo.objects[o].vertex_begin; v < topo.objects[o].vertex_end; ++v) friction_override_[v] = mu;
  }
  if (!any) friction_override_.clear();
}

std::vector<double> DetectingSolver::save_state() const {
  return detector_ ? detector_->reduced_offsets() : std::vector<double>();
}

void DetectingSolver::restore_state(std::span<const double> state) {
  if (!detector_) throw Error("contact solver '" + std::string(name()) + "': restore_state() before initialize()");
  detector_->restore_reduced_offsets(state);
}

void DetectingSolver::mark_substep() {
  if (detector_) detector_->mark_reduced_offsets();
}

void DetectingSolver::rewind_substep() {
  if (detector_) detector_->roll_back_reduced_offsets();
}

DetectResult DetectingSolver::detect(const Positions& anchor, const SimState& state, StepContext& ctx) {
  if (ctx.frame != rebuild_frame_) {
    rebuild_frame_ = ctx.frame;
    detector_->rebuild_broad_phase();
  }
  if (detector_->reuse_skin() > 0.0 && ctx.frame != reuse_frame_) {
    // Frame start: the kept list restarts from what a checkpoint holds (the velocities), so a
    // resumed run lists and reuses exactly where the uninterrupted one did (same stats.csv).
    // The last substep's step dt v, up to one common shift (a scene falling as a whole lists).
    reuse_frame_ = ctx.frame;
    reuse_step_.resize(state.v.size());
    reuse_zero_.assign(state.v.size(), Vec3::Zero());
    for (size_t i = 0; i < state.v.size(); ++i) reuse_step_[i] = ctx.dt * state.v[i];
    detector_->restart_reuse(measure_reuse_motion(ctx.topo, reuse_step_, reuse_zero_).spread);
  }
  DetectionStats ds;
  detector_->detect(anchor, state.inv_mass, regions_, contacts_, ds, ctx.kinematic_step, ctx.vertex_reach);
  ctx.times.broad += ds.broad_s;
  ctx.times.narrow += ds.narrow_s;
  ctx.times.broad_serial += ds.broad_serial_s;
  ctx.times.narrow_serial += ds.narrow_serial_s;
  {
    ScopedTimer t(ctx.times.narrow,
                  ctx.times.narrow_serial);  // contact bookkeeping for the response belongs to the narrow phase
    response_.prepare(contacts_, regions_.row_start, detector_->plane_sources(), ctx.params.contact,
                      response_mass(state));
  }
  DetectResult s;
  s.candidates = ds.candidates;
  s.constraints = ds.constraints;
  s.reused = ds.reused;
  for (const auto& c : contacts_) s.min_distance = std::min(s.min_distance, c.distance);
  return s;
}

namespace {
/// Exact distance of a sub-pair's primitives at x (closest points recomputed, not along n).
double pair_distance(const ContactPair& c, const Positions& x) {
  switch (c.kind) {
    case ContactKind::vf:
      return std::sqrt(point_triangle(x[c.v[0]], x[c.v[1]], x[c.v[2]], x[c.v[3]]).distance_sq);
    case ContactKind::ee:
      return std::sqrt(edge_edge(x[c.v[0]], x[c.v[1]], x[c.v[2]], x[c.v[3]]).distance_sq);
    case ContactKind::ve:
      return std::sqrt(point_edge(x[c.v[0]], x[c.v[1]], x[c.v[2]]).distance_sq);
    case ContactKind::vv:
      return std::sqrt(point_point_distance_sq(x[c.v[0]], x[c.v[1]]));
  }
  return 0.0;
}
}  // namespace

std::pair<Index, Index> DetectingSolver::mark_contact_vertices(int frame, std::span<const double> inv_mass) {
  const Index nv = regions_.num_vertices();
  if (frame != contact_marks_frame_ || static_cast<Index>(contact_marks_.size()) != nv) {
    contact_marks_.assign(static_cast<size_t>(nv), 0);
    contact_marks_frame_ = frame;
    contact_marks_count_ = 0;
  }
  // One sequential sweep over the offsets: a few microseconds per 10k vertices, far below detection.
  Index pass = 0;
  for (Index v = 0; v < nv; ++v) {
    if (!(inv_mass[v] > 0.0) || regions_.count(v) == 0) continue;
    ++pass;
    if (!contact_marks_[v]) contact_marks_[v] = 1, ++contact_marks_count_;
  }
  return {pass, contact_marks_count_};
}

Index DetectingSolver::contact_vertex_count(std::span<const double> inv_mass) const {
  std::vector<std::uint8_t> seen(inv_mass.size(), 0);
  Index n = 0;
  for (const auto& c : contacts_)
    for (int k = 0; k < c.size(); ++k)
      if (inv_mass[c.v[k]] > 0.0 && !seen[c.v[k]]) seen[c.v[k]] = 1, ++n;
  return n;
}

std::optional<Index> DetectingSolver::count_outside(const Positions& x, const Positions&, const SimState& state,
                                                    StepContext& ctx) const {
  const double keep = 1.0 - ctx.params.debug.audit_tolerance;
  // One rounding scale for every contact's bound: the largest |x|_1 (NaN or infinity if any
  // coordinate is, which makes every bound undecided and sends each pair to the exact distance).
  double scale = 0.0;
  for (const Vec3& p : x) {
    const double s = p.cwiseAbs().sum();
    scale = s > scale || std::isnan(s) ? s : scale;
  }
  std::atomic<Index> close{0};
  std::atomic<Index> first{std::numeric_limits<Index>::max()};
  if (!ctx.violated.empty()) pair_marks_.assign(ctx.violated.size(), 0);
  parallel_for(
      static_cast<Index>(contacts_.size()),
      [&](Index b, Index e) {
        Index local = 0;
        for (Index i = b; i < e; ++i) {
          // Most pairs are settled by the bound along their own normal, four dot products
          // instead of a distance kernel (after a CCFR projection every kept pair is).
          const double need = keep * contacts_[i].offset;
          if (separation_lower_bound(contacts_[i], x, scale) >= need) continue;
          if (!(pair_distance(contacts_[i], x) >= need)) {  // NaN counts
            ++local;
            if (!ctx.violated.empty())
              for (int k = 0; k < contacts_[i].size(); ++k)
                std::atomic_ref<std::uint8_t>(pair_marks_[contacts_[i].v[k]]).store(1, std::memory_order_relaxed);
            Index cur = first.load();
            while (i < cur && !first.compare_exchange_weak(cur, i)) {
            }
          }
        }
        close += local;
      },
      2048);
  // Distances alone miss a primitive swallowed whole: a scripted face that passes over a halted
  // vertex leaves it inside the solid, farther than the offset from every face, and the next pass
  // would push it deeper along the inward normal. An edge at a vertex-face pair's vertex that
  // crosses the face now and did not at the substep's start is counted as a violation.
  const Index crossed = count_new_crossings(x, state.x_prev, ctx, first);
  close += crossed;
  if (close.load() > 0 && !ctx.violated.empty()) {
    // The violated pairs' vertices and every vertex they share a contact with: a pair inside its
    // offset needs the room its neighbours give (with them fixed, its region can be empty).
    parallel_for(
        static_cast<Index>(contacts_.size()),
        [&](Index b, Index e) {
          for (Index i = b; i < e; ++i) {
            const ContactPair& c = contacts_[i];
            bool touches = false;
            for (int k = 0; k < c.size(); ++k) touches = touches || pair_marks_[c.v[k]];
            if (touches)
              for (int k = 0; k < c.size(); ++k)
                std::atomic_ref<std::uint8_t>(ctx.violated[c.v[k]]).store(1, std::memory_order_relaxed);
          }
        },
        4096);
  }
  if (crossed > 0 && first.load() == crossing_first_) {  // the lowest-numbered violation is a crossing
    const ContactPair& c = contacts_[first.load()];
    last_violation_ = "segment through a face: edge " + std::to_string(crossing_edge_) + " of '" +
                      ctx.topo.object_of_vertex(c.v[0]).name + "' (vertex " + std::to_string(c.v[0]) +
                      ") through the face of '" + ctx.topo.object_of_vertex(c.v[1]).name + "' (vertices " +
                      std::to_string(c.v[1]) + ", " + std::to_string(c.v[2]) + ", " + std::to_string(c.v[3]) +
                      "), crossed in this substep (the face passed over the vertex)";
  } else if (close.load() > 0) {
    // The lowest-numbered violation, so the message does not depend on the thread count.
    const ContactPair& c = contacts_[first.load()];
    const auto& topo = ctx.topo;
    auto obj = [&](Index v) { return "'" + topo.object_of_vertex(v).name + "'"; };
    static constexpr const char* kKind[] = {"vertex-face", "edge-edge", "vertex-edge", "vertex-vertex"};
    last_violation_ = std::string(kKind[static_cast<int>(c.kind)]) + " pair between " + obj(c.v[0]) + " (vertex " +
                      std::to_string(c.v[0]) + ") and " + obj(c.v[c.side_a()]) + " (vertex " +
                      std::to_string(c.v[c.side_a()]) + ") at distance " +
                      ccfr::format("{:.9g} ({:.6f} of its offset {:.6g})", pair_distance(c, x),
                                   pair_distance(c, x) / c.offset, c.offset);
  }
  return close.load();
}

Index DetectingSolver::count_new_crossings(const Positions& x, const Positions& x_start, StepContext& ctx,
                                           std::atomic<Index>& first) const {
  const Topology& topo = ctx.topo;
  crossing_first_ = std::numeric_limits<Index>::max();
  if (x_start.size() != x.size()) return 0;
  // The edge at contact i's vertex that crosses its face at x and did not at x_start, or -1.
  auto crossing_edge = [&](Index i) -> Index {
    const ContactPair& c = contacts_[i];
    if (c.kind != ContactKind::vf) return -1;
    const Index v = c.v[0];
    const Vec3 &a0 = x[c.v[1]], &a1 = x[c.v[2]], &a2 = x[c.v[3]];
    const Vec3 normal = (a1 - a0).cross(a2 - a0);
    const double side_v = normal.dot(x[v] - a0);
    for (Index k = topo.vertex_edges.row_start[v]; k < topo.vertex_edges.row_start[v + 1]; ++k) {
      const Vec2i& edge = topo.edges[topo.vertex_edges.indices[k]];
      const Index w = edge[0] == v ? edge[1] : edge[0];
      if (w == c.v[1] || w == c.v[2] || w == c.v[3]) continue;  // an edge to the face itself
      // A sure same side in floating point needs no exact predicate (the common case).
      const double side_w = normal.dot(x[w] - a0);
      const double slack = 1e-9 * normal.norm() * ((x[v] - a0).norm() + (x[w] - a0).norm());
      if ((side_v > slack && side_w > slack) || (side_v < -slack && side_w < -slack)) continue;
      if (exact::segment_crosses_triangle(x[v], x[w], a0, a1, a2) &&
          !exact::segment_crosses_triangle(x_start[v], x_start[w], x_start[c.v[1]], x_start[c.v[2]], x_start[c.v[3]]))
        return topo.vertex_edges.indices[k];
    }
    return -1;
  };
  std::atomic<Index> crossed{0};
  std::atomic<Index> lowest{std::numeric_limits<Index>::max()};
  parallel_for(
      static_cast<Index>(contacts_.size()),
      [&](Index b, Index e) {
        Index local = 0;
        for (Index i = b; i < e; ++i) {
          if (crossing_edge(i) < 0) continue;
          ++local;
          const ContactPair& c = contacts_[i];
          if (!ctx.violated.empty())
            for (int k = 0; k < c.size(); ++k)
              std::atomic_ref<std::uint8_t>(pair_marks_[c.v[k]]).store(1, std::memory_order_relaxed);
          Index cur = lowest.load();
          while (i < cur && !lowest.compare_exchange_weak(cur, i)) {
          }
        }
        crossed += local;
      },
      2048);
  if (crossed.load() == 0) return 0;
  const Index mine = lowest.load();
  Index cur = first.load();
  while (mine < cur && !first.compare_exchange_weak(cur, mine)) {
  }
  if (first.load() == mine) {
    crossing_first_ = mine;
    crossing_edge_ = crossing_edge(mine);
  }
  return crossed.load();
}

std::vector<ContactSolver::ClosePair> DetectingSolver::close_pairs(const Positions& x, double keep, size_t max) const {
  std::vector<ClosePair> out;
  for (const ContactPair& c : contacts_) {
    if (out.size() >= max) break;
    const double d = pair_distance(c, x);
    if (d >= keep * c.offset) continue;  // NaN counts, as in count_outside
    ClosePair p;
    p.kind = static_cast<int>(c.kind);
    p.size = c.size();
    p.side_a = c.side_a();
    for (int k = 0; k < c.size(); ++k) p.v[static_cast<size_t>(k)] = c.v[k];
    p.distance = d;
    p.offset = c.offset;
    out.push_back(p);
  }
  return out;
}

std::optional<bool> DetectingSolver::region_empty(Index v, const Positions& anchor) const {
  if (v < 0 || static_cast<size_t>(v) + 1 >= regions_.row_start.size() || regions_.count(v) == 0) return std::nullopt;
  std::vector<HalfSpace> buf;
  const auto planes = regions_.of(v, buf);
  if (!falls_below(anchor[v], anchor[v], planes, 0.0)) return false;  // the anchor is a feasible point
  // The anchor left its own region (a scripted step or a reduced offset moved a plane past it):
  // the exact projection decides, and reports an empty region as infeasible.
  const std::unique_ptr<Projector> exact = make_projector("exact", ProjectorParams{});
  return exact->project(anchor[v], anchor[v], planes).status == ProjectStatus::infeasible;
}

void DetectingSolver::respond(Positions& x, const Positions& anchor, const SimState& state, StepContext& ctx) {
  response_.apply(x, state.x_prev, state.inv_mass, ctx.params.contact, ctx.dt, friction_override_);
  if (ctx.momentum) response_.separate(x, anchor, state.inv_mass, kSeparateSweeps, rest_overlap(ctx), {}, ctx.tethers);
}

void DetectingSolver::vertex_diagnostics(std::vector<std::int32_t>& half_spaces, std::vector<double>& distance,
                                         std::vector<std::uint8_t>&) const {
  const Index n = num_vertices_;
  half_spaces.assign(static_cast<size_t>(n), 0);
  for (Index v = 0; v < std::min(n, regions_.num_vertices()); ++v)
    half_spaces[v] = static_cast<std::int32_t>(regions_.count(v));
  distance.assign(static_cast<size_t>(n), std::numeric_limits<double>::quiet_NaN());
  for (const ContactPair& c : contacts_)
    for (int k = 0; k < c.size(); ++k) {
      double& d = distance[static_cast<size_t>(c.v[k])];
      if (!(d <= c.distance)) d = c.distance;  // NaN (none yet) or farther
    }
}

}  // namespace ccfr
