// contact.free_islands: the pieces (bodies, single strands, single grains) one
// substep's contacts join, with nothing pinned, scripted or fixed among them, get back the linear
// and angular momentum the projection took (docs/feasibility.md, "A free island keeps its momentum").
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <span>
#include <utility>
#include <vector>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry/aabb.hpp"
#include "ccfr/solvers/rigid_bodies.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "ccfr/solvers/step_bound.hpp"

namespace ccfr {

Index Simulation::island_of(Index o) {
  while (island_parent_[o] != o) o = island_parent_[o] = island_parent_[island_parent_[o]];
  return o;
}

void Simulation::build_pieces() {
  const auto& topo = scene_.topo;
  const Index nv = topo.num_vertices();
  // A strand object's pieces are the connected runs of its segments (union-find over vertices).
  std::vector<Index> up(static_cast<size_t>(nv));
  std::iota(up.begin(), up.end(), Index{0});
  auto find = [&](Index v) {
    while (up[v] != v) v = up[v] = up[up[v]];
    return v;
  };
  for (Index e = 0; e < topo.num_edges(); ++e)
    if (topo.objects[topo.edge_object[e]].kind == ObjectKind::strand) {
      const Index a = find(topo.edges[e][0]), b = find(topo.edges[e][1]);
      if (a != b) up[std::max(a, b)] = std::min(a, b);
    }
  vertex_piece_.assign(static_cast<size_t>(nv), -1);
  piece_object_.clear();
  auto new_piece = [&](Index o) {
    piece_object_.push_back(o);
    return static_cast<Index>(piece_object_.size()) - 1;
  };
  for (Index o = 0; o < static_cast<Index>(topo.objects.size()); ++o) {
    const auto& obj = topo.objects[o];
    if (obj.num_vertices() == 0) continue;
    const Index whole = obj.kind == ObjectKind::strand || obj.kind == ObjectKind::particles ? -1 : new_piece(o);
    for (Index v = obj.vertex_begin; v < obj.vertex_end; ++v) {
      if (whole >= 0 || obj.kind == ObjectKind::particles) {
        vertex_piece_[v] = whole >= 0 ? whole : new_piece(o);
        continue;
      }
      const Index r = find(v);  // the run's lowest vertex: visited first, so its piece exists
      vertex_piece_[v] = r == v ? new_piece(o) : vertex_piece_[r];
    }
  }
  const auto np = static_cast<Index>(piece_object_.size());
  piece_first_.assign(static_cast<size_t>(np) + 1, 0);
  for (const Index p : vertex_piece_) ++piece_first_[static_cast<size_t>(p) + 1];
  std::partial_sum(piece_first_.begin(), piece_first_.end(), piece_first_.begin());
  piece_vertex_.resize(static_cast<size_t>(nv));
  std::vector<Index> fill(piece_first_.begin(), piece_first_.end() - 1);
  for (Index v = 0; v < nv; ++v) piece_vertex_[static_cast<size_t>(fill[vertex_piece_[v]]++)] = v;
  // A strand piece's segments, for the clear test's finer look (island_clear).
  piece_edge_first_.assign(static_cast<size_t>(np) + 1, 0);
  auto strand_edge = [&](Index e) { return topo.objects[topo.edge_object[e]].kind == ObjectKind::strand; };
  for (Index e = 0; e < topo.num_edges(); ++e)
    if (strand_edge(e)) ++piece_edge_first_[static_cast<size_t>(vertex_piece_[topo.edges[e][0]]) + 1];
  std::partial_sum(piece_edge_first_.begin(), piece_edge_first_.end(), piece_edge_first_.begin());
  piece_edge_.resize(static_cast<size_t>(piece_edge_first_.back()));
  fill.assign(piece_edge_first_.begin(), piece_edge_first_.end() - 1);
  for (Index e = 0; e < topo.num_edges(); ++e)
    if (strand_edge(e)) piece_edge_[static_cast<size_t>(fill[vertex_piece_[topo.edges[e][0]]]++)] = e;
}

void Simulation::start_islands() {
  const auto& topo = scene_.topo;
  const auto& st = scene_.state;
  // Under the region-projection solvers only (free_islands_), as the group carry.
  islands_on_ = free_islands_ && analytic_obstacles_.empty() && contact_->detected_contacts();
  if (!islands_on_) return;
  const auto no = static_cast<Index>(topo.objects.size());
  if (object_core_.size() != static_cast<size_t>(no)) {
    build_pieces();
    // A rigid body's momentum counts its core, the mass at its centre that no vertex carries.
    object_core_.assign(static_cast<size_t>(no), 0.0);
    const RigidBodies bodies(topo, st, &scene_.params);
    for (Index o = 0; o < no; ++o) {
      const auto& obj = topo.objects[o];
      const Index b = obj.kind == ObjectKind::rigid && obj.num_vertices() > 0 ? bodies.body_of(obj.vertex_begin) : -1;
      if (b >= 0) object_core_[static_cast<size_t>(o)] = bodies.core_of(b);
    }
  }
  const auto np = static_cast<Index>(piece_object_.size());
  island_parent_.resize(static_cast<size_t>(np));
  std::iota(island_parent_.begin(), island_parent_.end(), Index{0});
  island_fixed_.assign(static_cast<size_t>(np), 0);
  bool any_free = false;
  for (Index p = 0; p < np; ++p) {
    // Obstacles are fixed, and so is a piece with a pinned or scripted vertex.
    bool fixed = topo.objects[piece_object_[p]].kind == ObjectKind::obstacle;
    for (Index i = piece_first_[p]; i < piece_first_[p + 1] && !fixed; ++i)
      fixed = !(st.inv_mass[piece_vertex_[i]] > 0.0);
    island_fixed_[static_cast<size_t>(p)] = fixed ? 1 : 0;
    any_free = any_free || !fixed;
  }
  islands_on_ = any_free;
}

void Simulation::join_islands(StepContext& ctx) {
  ctx.free_island = {};
  if (!islands_on_) return;
  // The piece pairs the contacts join, in contact order, gathered in parallel chunks (a pass of
  // the 50 layers holds about 10 M contacts: 0.65 s a frame of serial work when united one by
  // one); each chunk drops a pair its small table of the chunk's pairs has seen. Then united
  // serially, in chunk order. A dropped repeat would have found its two pieces in one island
  // already, so the unions, in their order, and the roots are those of the contacts one by one.
  const std::vector<ContactPair>& contacts = *contact_->detected_contacts();
  const Index n = static_cast<Index>(contacts.size());
  std::vector<std::vector<std::pair<Index, Index>>> joined(static_cast<size_t>(default_chunk_count(n)));
  parallel_chunks(n, static_cast<Index>(joined.size()), [&](Index chunk, Index b, Index e) {
    constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
    std::array<std::uint64_t, 64> seen;
    seen.fill(kEmpty);
    auto& out = joined[static_cast<size_t>(chunk)];
    for (Index i = b; i < e; ++i) {
      const ContactPair& c = contacts[i];
      const Index p0 = vertex_piece_[c.v[0]];
      for (int k = 1; k < c.size(); ++k) {
        const Index pk = vertex_piece_[c.v[k]];
        if (pk == p0) continue;
        const std::uint64_t key = static_cast<std::uint64_t>(p0) << 32 | static_cast<std::uint32_t>(pk);
        std::uint64_t& slot = seen[(key * 0x9E3779B97F4A7C15ull) >> 58];
        if (slot == key) continue;
        slot = key;
        out.emplace_back(p0, pk);
      }
    }
  });
  for (const auto& pairs : joined)
    for (const auto& [p0, pk] : pairs) {
      const Index a = island_of(p0), b = island_of(pk);
      if (a == b) continue;
      island_parent_[b] = a;
      island_fixed_[a] |= island_fixed_[b];
    }
  // Per piece whether its island is free (serial: island_of compresses paths), then per vertex.
  const auto np = static_cast<Index>(piece_object_.size());
  std::vector<std::uint8_t> free_piece(static_cast<size_t>(np));
  bool any = false;
  for (Index p = 0; p < np; ++p) {
    free_piece[static_cast<size_t>(p)] = island_fixed_[island_of(p)] ? 0 : 1;
    any = any || free_piece[static_cast<size_t>(p)];
  }
  if (!any) return;
  free_marks_.resize(vertex_piece_.size());
  parallel_for(
      static_cast<Index>(vertex_piece_.size()),
      [&](Index b, Index e) {
        for (Index v = b; v < e; ++v) free_marks_[v] = free_piece[static_cast<size_t>(vertex_piece_[v])];
      },
      4096);
  ctx.free_island = free_marks_;
}

namespace {
/// Cross-product matrix [a]×: [a]× b = a × b.
Eigen::Matrix3d cross_matrix(const Vec3& a) {
  Eigen::Matrix3d m;
  m << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return m;
}
}  // namespace

AABB Simulation::IslandMove::of(const AABB& b) const {
  if (!b.valid()) return b;
  AABB out = b;
  out.expand(AABB{b.lo + shift, b.hi + shift});
  out.inflate(arc);
  return out;
}

template <class F>
void Simulation::each_primitive_box(Index p, F&& f) const {
  const auto& topo = scene_.topo;
  const auto& obj = topo.objects[piece_object_[p]];
  auto box_of = [&](std::initializer_list<Index> vs) {
    AABB b;
    for (const Index v : vs) b.expand(anchor_[v]);
    return b;
  };
  if (obj.kind == ObjectKind::particles) {
    f(box_of({piece_vertex_[piece_first_[p]]}));
  } else if (obj.kind == ObjectKind::strand) {
    for (Index i = piece_edge_first_[p]; i < piece_edge_first_[p + 1]; ++i) {
      const Vec2i& e = topo.edges[piece_edge_[i]];
      f(box_of({e[0], e[1]}));
    }
    // A strand vertex on no segment collides as a point (it is then a piece of its own).
    if (piece_edge_first_[p] == piece_edge_first_[p + 1]) f(box_of({piece_vertex_[piece_first_[p]]}));
  } else {
    for (Index t = obj.face_begin; t < obj.face_end; ++t) {
      const Vec3i& tri = topo.faces[t];
      f(box_of({tri[0], tri[1], tri[2]}));
    }
  }
}

bool Simulation::pieces_apart(Index p, Index q, const IslandMove& move, double gap) {
  std::vector<AABB>& ps = clear_near_;
  ps.clear();
  each_primitive_box(p, [&](const AABB& b) { ps.push_back(move.of(b)); });
  std::vector<AABB>& qs = clear_scratch_;
  qs.clear();
  each_primitive_box(q, [&](const AABB& b) { qs.push_back(b); });
  return all_apart(ps, qs, gap, clear_sorted_);
}

Simulation::PieceIndex::PieceIndex(const std::vector<AABB>& box) {
  order.resize(box.size());
  std::iota(order.begin(), order.end(), Index{0});
  auto lo = [&](Index p) { return box[p].valid() ? box[p].lo.x() : std::numeric_limits<double>::infinity(); };
  std::sort(order.begin(), order.end(), [&](Index a, Index b) { return lo(a) < lo(b); });
  lo_x.reserve(box.size());
  for (const Index p : order) {
    lo_x.push_back(lo(p));
    if (box[p].valid()) width = std::max(width, box[p].hi.x() - box[p].lo.x());
  }
}

bool Simulation::island_clear(Index root, std::span<const Index> members, const IslandMove& move,
                              const std::vector<AABB>& box, const PieceIndex& index, double gap) {
  AABB swept;
  for (const Index p : members) swept.expand(box[p]);
  swept = move.of(swept);
  if (!swept.valid()) return false;
  // Every piece's box lies within its indexed one grown by its island's moves since, at most
  // index.drift, so only those indexed with lo.x in this window can come within gap of the swept box.
  const double reach = gap + index.drift;
  const auto from = std::lower_bound(index.lo_x.begin(), index.lo_x.end(), swept.lo.x() - reach - index.width);
  const auto to = std::upper_bound(from, index.lo_x.end(), swept.hi.x() + reach);
  for (auto it = from; it != to; ++it) {
    const Index q = index.order[static_cast<size_t>(it - index.lo_x.begin())];
    if (island_of(q) == root || !box[q].valid() || swept.apart(box[q], gap)) continue;
    // The island's box meets q's: look at the island's pieces, and where one's box meets q's, at
    // their primitives' (a strand's segments, a mesh's triangles, a grain).
    for (const Index p : members)
      if (!move.of(box[p]).apart(box[q], gap) && !pieces_apart(p, q, move, gap)) return false;
  }
  return true;
}

Simulation::IslandMembers Simulation::free_island_members(std::vector<AABB>& box) {
  // Counting sort of the pieces by root: each free island's pieces in piece order.
  const auto np = static_cast<Index>(piece_object_.size());
  IslandMembers out;
  out.first.assign(static_cast<size_t>(np) + 1, 0);
  out.member.resize(static_cast<size_t>(np));
  box.assign(static_cast<size_t>(np), AABB{});
  for (Index p = 0; p < np; ++p) {
    for (Index i = piece_first_[p]; i < piece_first_[p + 1]; ++i) box[p].expand(anchor_[piece_vertex_[i]]);
    const Index root = island_of(p);
    if (!island_fixed_[root]) ++out.first[static_cast<size_t>(root) + 1];
  }
  std::partial_sum(out.first.begin(), out.first.end(), out.first.begin());
  std::vector<Index> at(out.first.begin(), out.first.end() - 1);
  for (Index p = 0; p < np; ++p)
    if (!island_fixed_[island_of(p)]) out.member[static_cast<size_t>(at[island_of(p)]++)] = p;
  return out;
}

Index Simulation::restore_island_momentum(double dt) {
  if (!islands_on_) return 0;
  const auto& st = scene_.state;
  const auto& cp = scene_.params.contact;
  const auto np = static_cast<Index>(piece_object_.size());
  std::vector<AABB> box;
  const IslandMembers islands = free_island_members(box);
  PieceIndex index(box);
  auto members = [&](Index root) { return islands.of(root); };
  auto each_vertex = [&](Index root, auto&& f) {
    for (const Index p : members(root))
      for (Index i = piece_first_[p]; i < piece_first_[p + 1]; ++i) f(piece_vertex_[i]);
  };
  // Every point mass of the island: f(m, x, y, x_prev, v) per vertex (x its anchor, y its material
  // solve, v its velocity at the substep's start), and per rigid body with a core the core at the
  // body's centre (its vertices' masses are centred there, so the core moves with that centre).
  auto each_point = [&](Index root, auto&& f) {
    for (const Index p : members(root)) {
      double m = 0.0;
      Vec3 cx = Vec3::Zero(), cy = Vec3::Zero(), cprev = Vec3::Zero(), cv = Vec3::Zero();
      for (Index i = piece_first_[p]; i < piece_first_[p + 1]; ++i) {
        const Index v = piece_vertex_[i];
        const double mv = 1.0 / st.inv_mass[v];  // as the sweeps weigh it (> 0 in a free island)
        f(mv, anchor_[v], material_solved_[v], st.x_prev[v], st.v[v]);
        m += mv, cx += mv * anchor_[v], cy += mv * material_solved_[v], cprev += mv * st.x_prev[v];
        cv += mv * st.v[v];
      }
      const double core = object_core_[static_cast<size_t>(piece_object_[p])];
      if (core > 0.0 && m > 0.0) f(core, Vec3(cx / m), Vec3(cy / m), Vec3(cprev / m), Vec3(cv / m));
    }
  };
  const double r = cp.radius, gap = cp.offset + cp.repulsion_range;
  Index moved = 0;
  for (Index lowest = 0; lowest < np; ++lowest) {
    // Islands in the order of their lowest piece: the order the contacts joined them in does not matter.
    const Index root = island_of(lowest);
    if (members(root).empty() || members(root).front() != lowest) continue;
    // Linear momentum: the island's mass-weighted shortfall behind the material solve y.
    double mass = 0.0;
    Vec3 taken = Vec3::Zero();
    each_point(root, [&](double m, const Vec3& x, const Vec3& y, const Vec3&, const Vec3&) {
      mass += m, taken += m * (x - y);
    });
    if (!(mass > 0.0)) continue;
    bool changed = false;
    double travelled = 0.0;  // how far this island's moves may carry a point (m)
    const Vec3 t = -taken / mass;
    // Nothing taken (rounding), or a blow-up rather than a motion (cut as a long step is).
    if (t.allFinite() && t.norm() > 1e-12 * r && t.norm() <= kLongStepMost * r) {
      // Translated as one, the island keeps every distance within it along the way; against every
      // other piece its boxes swept along t must stay more than ξ + δ away.
      if (island_clear(root, members(root), IslandMove{t, 0.0}, box, index, gap)) {
        travelled += t.norm();
        index.drift = std::max(index.drift, travelled);
        each_vertex(root, [&](Index v) { anchor_[v] += t; });
        for (const Index p : members(root))
          if (box[p].valid()) box[p].lo += t, box[p].hi += t;
        changed = true;
      }
    }
    // Angular momentum about the island's centre c: L = Σ m (x - c) × (x - x_prev) per dt, against
    // the substep's start's, Σ m (x_prev - c_prev) × v (no force inside the island, contact or
    // material, may change it, nor gravity about the centre; the material sweeps' projection of
    // x + v dt onto a turning shape loses about (ω dt)² of it a substep). A turn θ about c
    // changes it by A θ to first order, A = -Σ m [p]×[q]× with p = x_prev - c, q = x - c (the
    // inertia tensor when the step is small); two Newton steps with A's pseudo-inverse (directions
    // of almost no inertia are not turned), together moving no vertex more than r, nor by more
    // than kMostTurn radians.
    const Index p0 = members(root).front();
    if (members(root).size() == 1 && piece_first_[p0 + 1] - piece_first_[p0] == 1) {  // a lone grain does not turn
      moved += changed ? 1 : 0;
      continue;
    }
    Vec3 c = Vec3::Zero(), cprev = Vec3::Zero();
    each_point(root, [&](double m, const Vec3& x, const Vec3&, const Vec3& prev, const Vec3&) {
      c += m * x, cprev += m * prev;
    });
    c /= mass, cprev /= mass;
    Vec3 goal = Vec3::Zero();
    double reach = 0.0;
    each_point(root, [&](double m, const Vec3& x, const Vec3&, const Vec3& prev, const Vec3& v) {
      goal += m * (prev - cprev).cross(dt * v);
      reach = std::max(reach, (x - c).norm());
    });
    constexpr double kMostTurn = 0.5;
    double arc_left = r, angle_left = kMostTurn;  // the turns' budget for this substep
    for (int newton = 0; newton < 2; ++newton) {
      Vec3 now = Vec3::Zero();
      Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
      each_point(root, [&](double m, const Vec3& x, const Vec3&, const Vec3& prev, const Vec3&) {
        const Vec3 q = x - c;
        now += m * q.cross(x - prev);
        a.noalias() -= m * cross_matrix(prev - c) * cross_matrix(q);
      });
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(a, Eigen::ComputeFullU | Eigen::ComputeFullV);
      const Vec3 sigma = svd.singularValues();
      Vec3 inv = Vec3::Zero();
      for (int k = 0; k < 3; ++k) inv[k] = sigma[k] > 1e-6 * sigma[0] ? 1.0 / sigma[k] : 0.0;
      const Vec3 theta = svd.matrixV() * inv.asDiagonal() * svd.matrixU().transpose() * (goal - now);
      // No turn left; else within the budget (a first-order step is not trusted beyond it).
      if (!theta.allFinite() || !(theta.norm() * reach > 1e-12 * r)) break;
      const double angle = std::min({theta.norm(), arc_left / reach, angle_left});
      if (!(angle * reach > 1e-12 * r)) break;
      arc_left -= angle * reach, angle_left -= angle;
      // Every point of the island moves along an arc no longer than angle · reach.
      if (!island_clear(root, members(root), IslandMove{Vec3::Zero(), angle * reach}, box, index, gap)) break;
      travelled += angle * reach;
      index.drift = std::max(index.drift, travelled);
      const Eigen::Matrix3d rot = Eigen::AngleAxisd(angle, theta.normalized()).toRotationMatrix();
      each_vertex(root, [&](Index v) { anchor_[v] = c + rot * (anchor_[v] - c); });
      for (const Index p : members(root)) {
        box[p] = AABB{};
        for (Index i = piece_first_[p]; i < piece_first_[p + 1]; ++i) box[p].expand(anchor_[piece_vertex_[i]]);
      }
      changed = true;
    }
    moved += changed ? 1 : 0;
  }
  return moved;
}

}  // namespace ccfr
