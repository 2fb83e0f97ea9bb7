#include "reuse_list.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"
#include "contact_sink.hpp"

namespace ccfr {

ReuseMotion measure_reuse_motion(const Topology& topo, std::span<const Vec3> x, std::span<const Vec3> ref,
                                 double* per_vertex) {
  const Index n = topo.num_vertices();
  if (static_cast<Index>(x.size()) != n || static_cast<Index>(ref.size()) != n)
    throw Error("measure_reuse_motion: expected " + std::to_string(n) + " positions, got " + std::to_string(x.size()) +
                " and " + std::to_string(ref.size()));
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const size_t num_objects = topo.objects.size();
  ReuseMotion m;
  m.still.assign(num_objects, 1);
  // Per object: whether any vertex moved (objects are contiguous vertex ranges, so this is cheap).
  for (size_t o = 0; o < num_objects; ++o) {
    const ObjectInfo& ob = topo.objects[o];
    for (Index v = ob.vertex_begin; v < ob.vertex_end; ++v)
      if (!(x[v] == ref[v])) {  // NaN counts as moved
        m.still[o] = 0;
        break;
      }
  }
  // Box of the moving objects' displacements and their largest length; maxima and minima only,
  // so the chunked reduction is exact for any thread count.
  const Index chunks = default_chunk_count(n);
  std::vector<AABB> boxes(static_cast<size_t>(chunks));
  std::vector<double> largest(static_cast<size_t>(chunks), 0.0);
  auto moving = [&](Index v) { return !m.still[static_cast<size_t>(topo.vertex_object[v])]; };
  parallel_chunks(n, chunks, [&](Index c, Index b, Index e) {
    AABB box;
    double l = 0.0;
    for (Index v = b; v < e; ++v) {
      if (!moving(v)) continue;
      const Vec3 d = x[v] - ref[v];
      const double len = d.norm();
      l = std::isnan(len) ? kInf : std::max(l, len);
      box.expand(d);
    }
    boxes[c] = box;
    largest[c] = l;
  });
  AABB all;
  for (Index c = 0; c < chunks; ++c) {
    all.expand(boxes[c]);
    m.largest = std::max(m.largest, largest[c]);
  }
  if (!std::isfinite(m.largest)) {
    m.spread = m.largest = kInf;
    if (per_vertex) std::fill(per_vertex, per_vertex + n, kInf);
    return m;
  }
  // The box centre is usually far better than t = 0 (a falling scene), but not always (the box of
  // a few displacements on a sphere can be off-centre): take whichever bounds the spread lower.
  const Vec3 centre = all.valid() ? all.center() : Vec3::Zero();
  std::vector<double> spread(static_cast<size_t>(chunks), 0.0);
  parallel_chunks(n, chunks, [&](Index c, Index b, Index e) {
    double s = 0.0;
    for (Index v = b; v < e; ++v)
      if (moving(v)) s = std::max(s, (x[v] - ref[v] - centre).norm());
    spread[c] = s;
  });
  const double centred = *std::max_element(spread.begin(), spread.end());
  if (centred < m.largest) {
    m.shift = centre;
    m.spread = centred;
  } else {
    m.spread = m.largest;
  }
  if (per_vertex) {
    const Vec3 t = m.shift;
    parallel_chunks(n, chunks, [&](Index, Index b, Index e) {
      for (Index v = b; v < e; ++v) {
        const double d = (x[v] - ref[v] - t).norm();
        per_vertex[v] = std::isnan(d) ? kInf : d;
      }
    });
  }
  return m;
}

namespace detail {

ListedSubPair ListedSubPair::make(ContactKind kind, Index a, Index b, Index slot, double dist_sq) {
  const double d = std::sqrt(dist_sq);
  float f = static_cast<float>(d);
  if (static_cast<double>(f) > d) f = std::nextafter(f, 0.0f);  // a lower bound, never above d
  return {a, b, slot, kind, f};
}

void SubPairList::set_skin(double skin) {
  if (!(skin >= 0.0) || !std::isfinite(skin))
    throw Error("CollisionDetector::set_reuse_skin: the skin must be finite and >= 0, got " + std::to_string(skin));
  skin_ = skin;
  valid_ = false;
  if (skin_ == 0.0) {
    chunks_.clear();
    chunks_.shrink_to_fit();
  }
}

void SubPairList::restart(double recent_step) {
  valid_ = false;
  last_x_.clear();
  restart_step_ = std::isfinite(recent_step) && recent_step >= 0.0 ? recent_step : -1.0;
}

double SubPairList::step_since_last_pass(const Topology& topo, const Positions& x) {
  double step = std::numeric_limits<double>::infinity();
  if (restart_step_ >= 0.0)
    step = restart_step_;
  else if (last_x_.size() == x.size())
    step = measure_reuse_motion(topo, x, last_x_).spread;
  restart_step_ = -1.0;
  last_x_ = x;
  return step;
}

namespace {
/// Euclidean distance between two boxes (0 if they overlap).
double box_distance(const AABB& a, const AABB& b) {
  const Vec3 gap = (a.lo - b.hi).cwiseMax(b.lo - a.hi).cwiseMax(0.0);
  return gap.norm();
}
}  // namespace

bool SubPairList::covers(const Topology& topo, const Positions& x, std::span<const double> inv_mass, double reach) {
  const Index nv = topo.num_vertices();
  if (static_cast<Index>(list_x_.size()) != nv || static_cast<Index>(list_movable_.size()) != nv) return false;
  for (Index v = 0; v < nv; ++v)
    if (list_movable_[v] != static_cast<std::uint8_t>(inv_mass[v] > 0.0)) return false;
  disp_.resize(static_cast<size_t>(nv));
  // A NaN gives infinity and fails the check: the pass then runs the broad phase, which reports it.
  const ReuseMotion m = measure_reuse_motion(topo, x, list_x_, disp_.data());
  // The relative margin covers the rounding of the listed distances and of the displacements.
  auto fits = [&](double move, double room) { return move <= room * (1.0 - 1e-9) - 1e-9 * reach; };
  // Two moving sides: each within `spread` of its listing position shifted by t, so a sub-pair
  // beyond 2r + ξ + s at listing is still beyond 2r + ξ while 2 spread <= s.
  if (!fits(2.0 * m.spread, skin_)) return false;
  // A moving side against a still one: the still side stayed put, so the pair came closer by at
  // most `largest`; it was at least max(2r + ξ + s, g) apart, g the distance of the boxes at listing.
  AABB movers;
  bool any_still = false;
  for (size_t o = 0; o < m.still.size(); ++o) {
    if (topo.objects[o].num_vertices() == 0) continue;
    if (m.still[o])
      any_still = true;
    else
      movers.expand(list_boxes_[o]);
  }
  if (!any_still || !movers.valid()) return true;
  double gap = std::numeric_limits<double>::infinity();
  for (size_t o = 0; o < m.still.size(); ++o)
    if (m.still[o] && topo.objects[o].num_vertices() > 0) gap = std::min(gap, box_distance(list_boxes_[o], movers));
  return fits(m.largest, std::max(skin_, gap - reach));
}

void SubPairList::record(const Topology& topo, const Positions& x, std::span<const double> inv_mass) {
  const Index nv = topo.num_vertices();
  list_x_ = x;
  list_boxes_.assign(topo.objects.size(), AABB{});
  for (size_t o = 0; o < topo.objects.size(); ++o)
    for (Index v = topo.objects[o].vertex_begin; v < topo.objects[o].vertex_end; ++v) list_boxes_[o].expand(x[v]);
  list_movable_.resize(static_cast<size_t>(nv));
  for (Index v = 0; v < nv; ++v) list_movable_[v] = inv_mass[v] > 0.0;
  valid_ = true;
}

void SubPairList::evaluate(const Topology& topo, const Positions& x, std::span<const double> inv_mass,
                           const InitialPairs& initial, const ContactModel& params, ContactWaves& waves,
                           std::vector<ContactPair>& contacts, DetectionStats& stats) const {
  const Index chunks = static_cast<Index>(chunks_.size());
  std::vector<DetectionStats> counts(static_cast<size_t>(chunks));
  // A listed sub-pair is evaluated unless its lower bound (listed distance less the largest
  // displacement of each side) already clears the range, with a margin for rounding.
  const double clear = (2.0 * params.radius + params.offset) * (1.0 + 1e-9) + 1e-12;
  waves.collect(
      chunks,
      [&](Index chunk, std::vector<ContactPair>& out) {
        ContactSink sink{topo, x, contact_policy(inv_mass, initial, params, out)};
        const auto& d = disp_;
        for (const ListedSubPair& p : chunks_[chunk]) {
          const double listed = p.distance;
          switch (p.kind) {
            case ContactKind::vf: {
              const Vec3i& t = topo.faces[p.b];
              if (listed - d[p.a] - std::max({d[t[0]], d[t[1]], d[t[2]]}) >= clear) continue;
              sink.vf_eval(p.a, p.b, p.slot);
              break;
            }
            case ContactKind::ee: {
              const Vec2i &ea = topo.edges[p.a], &eb = topo.edges[p.b];
              if (listed - std::max(d[ea[0]], d[ea[1]]) - std::max(d[eb[0]], d[eb[1]]) >= clear) continue;
              sink.ee_eval(p.a, p.b, p.slot);
              break;
            }
            case ContactKind::ve: {
              const Vec2i& e = topo.edges[p.b];
              if (listed - d[p.a] - std::max(d[e[0]], d[e[1]]) >= clear) continue;
              sink.ve_eval(p.a, p.b, p.slot);
              break;
            }
            case ContactKind::vv:
              if (listed - d[p.a] - d[p.b] >= clear) continue;
              sink.vv_eval(p.a, p.b, p.slot);
              break;
          }
        }
        sink.policy.add_to(counts[chunk]);
      },
      contacts);
  for (Index c = 0; c < chunks; ++c) {
    add_counts(stats, counts[c]);
    stats.listed += static_cast<Index>(chunks_[c].size());
  }
}

}  // namespace detail
}  // namespace ccfr
