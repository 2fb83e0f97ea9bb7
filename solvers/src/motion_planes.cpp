#include "ccfr/solvers/motion_planes.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>

#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry/distance.hpp"

namespace ccfr {

namespace {
/// Least room a retreating side must vacate, as a share of the other side's cut, to defer it.
constexpr double kVacated = 0.1;
/// Cyclic-projection sweeps for a vertex's least push (push_through).
constexpr int kPushSweeps = 8;
/// Past the gap, the weaker of two opposed pushes must be at most this share of the stronger for
/// the stronger to carry the plane (push_through); comparable pushes are a squeeze, left alone.
constexpr double kPushDominance = 0.25;
/// Most a side may advance past the gap toward the other, as a share of the pair's offset: with
/// the other side left at its anchor (its region empty, the vertex halted) the pair still keeps
/// (1 - kPushReach) ξ, so no push can carry one primitive through the other (push_through).
constexpr double kPushReach = 0.5;
/// Room a side pushed past the gap gets beyond its push, as a share of the push, in the first
/// round (push_through): the push is a bound along n alone, the vertex's other planes may ask more.
constexpr double kPushMargin = 0.1;
/// Least share of its mass share a side of a pair of two unpinned rigid bodies keeps when the
/// split follows their motion (split_by_motion).
constexpr double kPairShareFloor = 0.1;
}  // namespace

Index split_by_motion(RegionSet& regions, std::span<const ContactPair> contacts, const Positions& anchor,
                      const Positions& x, std::span<const double> inv_mass, std::span<const double> responds,
                      std::vector<HeldSplit>& held, std::span<const double> other_inverse_mass,
                      std::span<const std::uint8_t> paired) {
  held.clear();
  if (regions.records.size() != contacts.size()) return 0;
  std::mutex gather;
  parallel_for(
      static_cast<Index>(contacts.size()),
      [&](Index b, Index e) {
        std::vector<HeldSplit> local;
        for (Index ci = b; ci < e; ++ci) {
          const ContactPair& c = contacts[ci];
          RegionRecord& rec = regions.records[static_cast<size_t>(ci)];
          // A turned plane (scripted vertices on a side) and mesh neighbours (their distance is the
          // material's; the response leaves them too) keep the paper's split.
          if (rec.n != c.n || c.neighbours) continue;
          const double gap = rec.d[0] + rec.d[1];
          if (!(gap >= 0.0)) continue;
          const int na = c.side_a(), nk = c.size();
          bool all_free = true, answers[2] = {responds.empty(), responds.empty()};
          double w_a = 0.0, w_b = 0.0;
          double a_a = -std::numeric_limits<double>::infinity(), a_b = a_a;
          for (int k = 0; k < nk && all_free; ++k) {
            const Index v = c.v[k];
            all_free = inv_mass[v] > 0.0;
            if (!responds.empty()) answers[k < na ? 0 : 1] |= responds[v] > 0.0;
            const double along = c.n.dot(x[v] - anchor[v]);
            if (k < na) {
              w_a += c.w[k] * inv_mass[v];
              a_a = std::max(a_a, -along);
            } else {
              w_b -= c.w[k] * inv_mass[v];
              a_b = std::max(a_b, along);
            }
          }
          // Two rigid bodies: each pose solve takes the pair as if the other were fixed, so the
          // paper's split stays (a split by their predictions would leave each a share it cannot
          // use), unless answer_pairs() made their candidates one pair's answer (`paired`).
          // A rigid body answering for itself: its generalized inverse mass at the contact, as the
          // response took it (its vertices' own masses would make it a light cloth).
          const double w_o = other_inverse_mass.empty() ? 0.0 : other_inverse_mass[static_cast<size_t>(ci)];
          if (w_o > 0.0 && answers[0] != answers[1]) (answers[0] ? w_b : w_a) = w_o;
          const bool pair = paired.size() == contacts.size() && paired[static_cast<size_t>(ci)] == 1;
          if (!all_free || !(answers[0] || answers[1] || pair) || !(w_a + w_b > 0.0) || !std::isfinite(a_a + a_b))
            continue;
          const double s_a = w_a / (w_a + w_b);
          const double raw = a_a + s_a * (gap - a_a - a_b);
          // Two rigid bodies keep a tenth of their mass shares: a pose solve turning a body about
          // a contact held at its anchor (d = 0) pushes some vertex into the plane, and halts.
          const double lo = pair ? kPairShareFloor * std::max(0.0, rec.d[0]) : 0.0;
          const double hi = pair ? gap - kPairShareFloor * std::max(0.0, rec.d[1]) : gap;
          const double d_a = std::clamp(raw, lo, hi);
          rec.d[0] = d_a;
          rec.d[1] = gap - d_a;
          // A side clamped at its anchor while it moves away: the other side may wait for the next
          // pass, if this one lets the retreating side go (held_followers).
          const double tol = 1e-9 * gap;
          if (raw < lo && a_b > rec.d[1] + tol && a_a < 0.0)
            local.push_back({ci, 1, a_b - rec.d[1]});
          else if (raw > hi && a_a > rec.d[0] + tol && a_b < 0.0)
            local.push_back({ci, 0, a_a - rec.d[0]});
        }
        if (local.empty()) return;
        const std::lock_guard<std::mutex> lock(gather);
        held.insert(held.end(), local.begin(), local.end());
      },
      2048);
  return static_cast<Index>(held.size());
}

Index push_through(RegionSet& regions, std::span<const ContactPair> contacts, std::span<const double> inv_mass,
                   std::span<const double> responds, int rounds) {
  if (regions.records.size() != contacts.size() || rounds <= 0) return 0;
  const Index nv = regions.num_vertices();
  // forcing[ci]: the contact's plane may push a movable side out of its anchor (d < 0) and the
  // push is to be passed on: a side that cannot move (fixed or scripted), a pair inside its
  // offset, or a pair pushed here.
  std::vector<std::uint8_t> forcing(contacts.size(), 0);
  std::vector<Index> frontier;
  std::vector<std::uint8_t> queued(static_cast<size_t>(nv), 0);
  auto queue_negative_sides = [&](size_t ci) {
    const ContactPair& c = contacts[ci];
    const RegionRecord& rec = regions.records[ci];
    for (int k = 0; k < c.size(); ++k) {
      const Index v = c.v[k];
      if (inv_mass[v] > 0.0 && rec.d[k < c.side_a() ? 0 : 1] < 0.0 && !queued[static_cast<size_t>(v)]) {
        queued[static_cast<size_t>(v)] = 1;
        frontier.push_back(v);
      }
    }
  };
  for (size_t ci = 0; ci < contacts.size(); ++ci) {
    const ContactPair& c = contacts[ci];
    bool pinned = false;
    for (int k = 0; k < c.size(); ++k) pinned = pinned || !(inv_mass[c.v[k]] > 0.0);
    const RegionRecord& rec = regions.records[ci];
    if (!pinned && !(rec.d[0] < 0.0 || rec.d[1] < 0.0)) continue;
    forcing[ci] = 1;
    queue_negative_sides(ci);
  }
  std::vector<Vec3> push(static_cast<size_t>(nv), Vec3::Zero());
  Index moved = 0;
  for (int round = 0; round < rounds && !frontier.empty(); ++round) {
    // Each queued vertex's least push: a point of its forcing planes' intersection, found by
    // cyclic projection from its anchor (step 0), the planes (n, d) asking n·f >= -d.
    for (const Index v : frontier) {
      Vec3 f = Vec3::Zero();
      for (int sweep = 0; sweep < kPushSweeps; ++sweep) {
        bool short_of = false;
        for (Index q = regions.row_start[v]; q < regions.row_start[v + 1]; ++q) {
          const std::uint32_t ref = regions.refs[static_cast<size_t>(q)];
          if (!forcing[ref >> 1]) continue;
          const HalfSpace h = regions.plane_of_ref(ref);
          const double value = f.dot(h.n) + h.d;
          if (value < 0.0) {
            f -= value * h.n;
            short_of = true;
          }
        }
        if (!short_of) break;
      }
      push[static_cast<size_t>(v)] = f;
    }
    // Halved each round, so that a chain's pushes grow by at most e^(2 kPushMargin) in all.
    const double margin = std::ldexp(kPushMargin, -round);
    std::vector<Index> next;
    std::swap(next, frontier);
    for (const Index v : next) queued[static_cast<size_t>(v)] = 0;  // a later push queues it again
    for (const Index v : next) {
      for (Index q = regions.row_start[v]; q < regions.row_start[v + 1]; ++q) {
        const size_t ci = regions.refs[static_cast<size_t>(q)] >> 1;
        const ContactPair& c = contacts[ci];
        if (forcing[ci] || c.neighbours) continue;
        bool free = true;
        for (int k = 0; k < c.size(); ++k)
          free = free && inv_mass[c.v[k]] > 0.0 && (responds.empty() || responds[c.v[k]] > 0.0);
        if (!free) continue;
        RegionRecord& rec = regions.records[ci];
        const double gap = rec.d[0] + rec.d[1];
        if (!(gap >= 0.0)) continue;
        // How far each side's pushes carry it toward the other along n.
        double in_a = 0.0, in_b = 0.0;
        for (int k = 0; k < c.size(); ++k) {
          const double along = rec.n.dot(push[static_cast<size_t>(c.v[k])]);
          if (k < c.side_a())
            in_a = std::max(in_a, -along);
          else
            in_b = std::max(in_b, along);
        }
        if (in_a <= rec.d[0] && in_b <= rec.d[1]) continue;
        // The pushes are lower bounds along n alone (the vertex's other planes may ask more):
        // a side pushed gets the room its push takes and a share of what is left.
        const double s_a = gap > 0.0 ? rec.d[0] / gap : 0.5;
        if (in_a + in_b <= gap) {
          // Both pushes fit in the gap: the dividing plane moves to give each its push.
          rec.d[0] = in_a + s_a * (gap - in_a - in_b);
          rec.d[1] = gap - rec.d[0];
        } else if (std::min(in_a, in_b) > kPushDominance * std::max(in_a, in_b)) {
          continue;  // pushed from both sides alike: a squeeze no dividing plane resolves
        } else if (in_a >= in_b) {
          // Past the gap a push four times the other's carries the plane, and the other side is
          // pushed on by what it takes past the gap (a side pushed a little toward the other can
          // often meet its own planes by moving sideways: its push is one point of them).
          rec.d[0] = std::min(in_a * (1.0 + margin), gap + kPushReach * c.offset);
          rec.d[1] = gap - rec.d[0];
        } else {
          rec.d[1] = std::min(in_b * (1.0 + margin), gap + kPushReach * c.offset);
          rec.d[0] = gap - rec.d[1];
        }
        ++moved;
        if (rec.d[0] < 0.0 || rec.d[1] < 0.0) {
          forcing[ci] = 1;
          queue_negative_sides(ci);
        }
      }
    }
  }
  return moved;
}

Index held_followers(std::span<const ContactPair> contacts, std::span<const HeldSplit> held, const Positions& anchor,
                     const Positions& x, double min_room, std::span<std::uint8_t> deferred) {
  Index count = 0;
  for (const HeldSplit& h : held) {
    const ContactPair& c = contacts[static_cast<size_t>(h.contact)];
    const int na = c.side_a(), nk = c.size();
    // The retreating side's least retreat along n at x: the room its plane vacated.
    const int lo = h.side == 0 ? na : 0, hi = h.side == 0 ? nk : na;
    double vacated = std::numeric_limits<double>::infinity();
    for (int k = lo; k < hi; ++k) {
      const double along = c.n.dot(x[c.v[k]] - anchor[c.v[k]]);
      vacated = std::min(vacated, h.side == 0 ? -along : along);
    }
    // Only where the room vacated is a fair part of the cut: a side that barely retreats
    // from an overlap the response left gives the next pass nothing to use.
    if (!(vacated > std::max(min_room, kVacated * h.cut))) continue;
    ++count;
    if (!deferred.empty())
      for (int k = h.side == 0 ? 0 : na; k < (h.side == 0 ? na : nk); ++k) deferred[static_cast<size_t>(c.v[k])] = 1;
  }
  return count;
}

Index follow_resolved_sides(RegionSet& regions, std::span<const ContactPair> contacts, const Positions& anchor,
                            const Positions& x, std::span<const double> later) {
  if (regions.records.size() != contacts.size() || later.empty()) return 0;
  std::atomic<Index> count{0};
  parallel_for(
      static_cast<Index>(contacts.size()),
      [&](Index b, Index e) {
        Index local = 0;
        for (Index ci = b; ci < e; ++ci) {
          const ContactPair& c = contacts[ci];
          if (c.neighbours) continue;
          RegionRecord& rec = regions.records[static_cast<size_t>(ci)];
          const double gap = rec.d[0] + rec.d[1];
          if (!(gap >= 0.0)) continue;
          const int na = c.side_a(), nk = c.size();
          int later_on[2] = {0, 0};
          for (int k = 0; k < nk; ++k) later_on[k < na ? 0 : 1] += later[c.v[k]] > 0.0;
          const int side_later = later_on[0] == na && later_on[1] == 0        ? 0
                                 : later_on[1] == nk - na && later_on[0] == 0 ? 1
                                                                              : -1;
          if (side_later < 0) continue;
          // The resolved side's largest approach toward the later one along n.
          double approach = -std::numeric_limits<double>::infinity();
          for (int k = side_later == 0 ? na : 0; k < (side_later == 0 ? nk : na); ++k) {
            const double along = rec.n.dot(x[c.v[k]] - anchor[c.v[k]]);
            approach = std::max(approach, side_later == 0 ? along : -along);
          }
          const double room = gap - approach;
          if (!(room > rec.d[side_later])) continue;
          rec.d[side_later] = room;
          rec.d[1 - side_later] = gap - room;
          ++local;
        }
        count += local;
      },
      2048);
  return count.load();
}

Index mark_carried(std::span<const ContactPair> contacts, const RegionSet& regions, const Positions& anchor,
                   const Positions& x, std::span<const Index> body, std::span<const double> movable,
                   std::vector<Index>& carrier) {
  const size_t nv = x.size();
  carrier.assign(nv, -1);
  if (regions.records.size() != contacts.size()) return 0;
  // Per vertex: the body of its contacts (-1: none yet) and bits 1 (cut), 2 (left), 4 (two bodies).
  std::vector<Index> toward(nv, -1);
  std::vector<std::uint8_t> seen(nv, 0);
  auto one_body = [&](const ContactPair& c, int lo, int hi) {
    const Index b = body[c.v[lo]];
    for (int k = lo; k < hi && b >= 0; ++k)
      if (body[c.v[k]] != b) return Index{-1};
    return b;
  };
  parallel_for(
      static_cast<Index>(contacts.size()),
      [&](Index b, Index e) {
        for (Index ci = b; ci < e; ++ci) {
          const ContactPair& c = contacts[ci];
          if (c.neighbours) continue;
          const RegionRecord& rec = regions.records[static_cast<size_t>(ci)];
          const double gap = rec.d[0] + rec.d[1];
          if (!(gap >= 0.0)) continue;
          const int na = c.side_a(), nk = c.size();
          const Index body_a = one_body(c, 0, na), body_b = one_body(c, na, nk);
          const int on_body = body_a >= 0 ? 0 : body_b >= 0 ? 1 : -1;
          if (on_body < 0) continue;
          const int lo = on_body == 0 ? na : 0, hi = on_body == 0 ? nk : na;
          bool all_movable = true;
          for (int k = lo; k < hi; ++k) all_movable = all_movable && movable[c.v[k]] > 0.0 && body[c.v[k]] < 0;
          if (!all_movable) continue;
          // The body's largest advance toward the movable side (side A gives way along +n).
          double approach = -std::numeric_limits<double>::infinity();
          for (int k = on_body == 0 ? 0 : na; k < (on_body == 0 ? na : nk); ++k) {
            const double along = rec.n.dot(x[c.v[k]] - anchor[c.v[k]]);
            approach = std::max(approach, on_body == 0 ? -along : along);
          }
          const std::uint8_t bit = approach > gap ? 1 : approach < 0.0 ? 2 : 0;
          const Index carrier_body = on_body == 0 ? body_a : body_b;
          for (int k = lo; k < hi; ++k) {
            const size_t v = static_cast<size_t>(c.v[k]);
            std::atomic_ref<Index> t(toward[v]);
            Index expected = -1;
            const bool other = !t.compare_exchange_strong(expected, carrier_body) && expected != carrier_body;
            std::atomic_ref<std::uint8_t>(seen[v]).fetch_or(static_cast<std::uint8_t>(bit | (other ? 4 : 0)));
          }
        }
      },
      2048);
  Index count = 0;
  for (size_t v = 0; v < nv; ++v)
    if (seen[v] == 3) carrier[v] = toward[v], ++count;
  return count;
}

bool moves_with_one_body(const ContactPair& c, std::span<const Index> body, std::span<const Index> carrier) {
  Index on = -1;
  for (int k = 0; k < c.size(); ++k) {
    const Index v = c.v[k];
    const Index b = body[v] >= 0 ? body[v] : carrier[v];
    if (b < 0 || (on >= 0 && b != on)) return false;
    on = b;
  }
  return true;
}

namespace {
/// Direction from side B's closest point to side A's at x (not normalised; zero where they meet).
Vec3 closest_direction(const ContactPair& c, const Positions& x) {
  switch (c.kind) {
    case ContactKind::vf:
      return x[c.v[0]] - point_triangle(x[c.v[0]], x[c.v[1]], x[c.v[2]], x[c.v[3]]).closest;
    case ContactKind::ee: {
      const EdgeEdgeResult r = edge_edge(x[c.v[0]], x[c.v[1]], x[c.v[2]], x[c.v[3]]);
      return r.pa - r.pb;
    }
    case ContactKind::ve:
      return x[c.v[0]] - point_edge(x[c.v[0]], x[c.v[1]], x[c.v[2]]).closest;
    case ContactKind::vv:
      return x[c.v[0]] - x[c.v[1]];
  }
  return Vec3::Zero();
}

/// G(m) over the anchors (turn_by_motion).
double gap_along(const ContactPair& c, const Vec3& m, const Positions& anchor) {
  double lo_a = std::numeric_limits<double>::infinity(), hi_b = -lo_a;
  for (int k = 0; k < c.size(); ++k) {
    const double along = m.dot(anchor[c.v[k]]);
    if (k < c.side_a())
      lo_a = std::min(lo_a, along);
    else
      hi_b = std::max(hi_b, along);
  }
  return lo_a - hi_b - c.offset;
}

/// Summed shortfall of the movable candidates from their planes (m, d_A) and (-m, d_B), each
/// plane's target raised to the repulsion's reach max(0, δ - d_other) (turn_by_motion). `step`:
/// per vertex x - a (m), NaN where immovable, whose term max(0, NaN) is then +0: no term.
double shortfall_along(const ContactPair& c, const Vec3& m, double d_a, double d_b, double reach,
                       std::span<const Vec3> step) {
  const double want_a = std::max(0.0, reach - d_b), want_b = std::max(0.0, reach - d_a);
  double shortfall = 0.0;
  for (int k = 0; k < c.size(); ++k) {
    const double along = m.dot(step[c.v[k]]);
    shortfall += k < c.side_a() ? std::max(0.0, want_a - along - d_a) : std::max(0.0, want_b + along - d_b);
  }
  return shortfall;
}
}  // namespace

Index turn_by_motion(std::span<ContactPair> contacts, RegionSet& regions, const Positions& anchor, const Positions& x,
                     std::span<const double> inv_mass, std::span<const Vec3> kinematic_step, double repulsion_range) {
  if (regions.records.size() != contacts.size()) return 0;
  const double reach = std::max(0.0, repulsion_range);
  // Each vertex's step once: one 24-byte read per candidate where x, a and m⁻¹ took three.
  std::vector<Vec3> step(x.size());
  parallel_for(
      static_cast<Index>(x.size()),
      [&](Index b, Index e) {
        for (Index v = b; v < e; ++v)
          step[v] =
              inv_mass[v] > 0.0 ? Vec3(x[v] - anchor[v]) : Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
      },
      4096);
  std::atomic<Index> count{0};
  parallel_for(
      static_cast<Index>(contacts.size()),
      [&](Index b, Index e) {
        Index local = 0;
        for (Index ci = b; ci < e; ++ci) {
          ContactPair& c = contacts[static_cast<size_t>(ci)];
          RegionRecord& rec = regions.records[static_cast<size_t>(ci)];
          const double gap = rec.d[0] + rec.d[1];
          if (rec.n != c.n || c.neighbours || !(gap > 0.0)) continue;
          bool scripted = false;
          for (int k = 0; k < c.size() && !kinematic_step.empty(); ++k)
            scripted = scripted || kinematic_step[c.v[k]] != Vec3::Zero();
          if (scripted) continue;
          double best = shortfall_along(c, c.n, rec.d[0], rec.d[1], reach, step);
          if (!(best > 0.0)) continue;
          const Vec3 toward = closest_direction(c, x);
          const double len = toward.norm();
          // Where the candidates have crossed (m₁ against n) its direction is not a surface's.
          if (!(len > 1e-12) || !(toward.dot(c.n) > 0.0)) continue;
          // A turn must at least halve the shortfall, so only a plane that blocks the motion
          // turns: turning every pair for a sliver of shortfall (m₁ is a resting pair's n up to
          // the candidates' jitter) let the three cubes' friction fail and one slide off the floor.
          const double first = best;
          const double s_a = rec.d[0] / gap;
          const Vec3 n = c.n;
          for (const double t : {1.0, 0.5}) {
            const Vec3 u = (1.0 - t) * n + (t / len) * toward;
            const double ul = u.norm();
            if (!(ul > 1e-12)) continue;
            const Vec3 m = u / ul;
            const double g = gap_along(c, m, anchor);
            if (!(g >= 0.0)) continue;
            const double d_a = s_a * g, d_b = g - d_a;
            const double here = shortfall_along(c, m, d_a, d_b, reach, step);
            if (!(here < best && here <= 0.5 * first)) continue;
            best = here;
            rec = {m, {d_a, d_b}};
            c.n = m;
            c.distance = g + c.offset;
          }
          local += c.n != n;
        }
        count += local;
      },
      2048);
  return count.load();
}

}  // namespace ccfr
