// Inelastic contact between two unpinned rigid bodies and their supports (contact.momentum): impulses on the poses.
#include <algorithm>
#include <vector>

#include "ccfr/solvers/rigid_bodies.hpp"

namespace ccfr {

namespace {

/// One contact between two bodies: the arms of its closest points' midpoint about the bodies'
/// centres at the candidates, its generalized inverse mass along n, and its accumulated impulse
/// (kg m).
struct PairContact {
  Index a = -1, b = -1;  ///< the bodies of sides A and B (b = -1: a side that cannot move)
  Vec3 n = Vec3::Zero();
  Vec3 arm_a = Vec3::Zero(), arm_b = Vec3::Zero();
  double base = 0.0;  ///< C at the candidates before any impulse (m), rest included
  double w = 0.0;     ///< w_A + w_B
  double lambda = 0.0;
  double gap = 0.0;       ///< the pair's gap beyond ξ at the candidates before any impulse (m)
  double lambda_r = 0.0;  ///< the repulsion's accumulated impulse (kg m)
  size_t contact = 0;     ///< its index in the contact list
};

/// The body holding every vertex of `c` in [lo, hi), or -1 (none, or more than one).
Index side_body(const RigidBodies& rigid, const ContactPair& c, int lo, int hi) {
  const Index body = rigid.body_of(c.v[lo]);
  for (int k = lo + 1; k < hi; ++k)
    if (rigid.body_of(c.v[k]) != body) return -1;
  return body;
}

/// One contact answer_pairs() takes: a body on each side, or one body and a side that cannot move.
struct Found {
  const ContactPair* c;
  Index a, b;         ///< b = -1: a side that cannot move
  double sign = 1.0;  ///< -1: the body is on side B, so it is pushed along -n
};

/// The contacts between two different unpinned bodies first (most scenes have none: no fit is
/// needed), then those of a body so paired with a side that cannot move (a floor, a pinned body):
/// one-sided, they hold the pair's pushes and turns as the real support does. Left to the pose
/// solve, a box pressed onto a floor by the one above was pushed and turned into it, and its solve,
/// starting from an anchor resting on the floor's plane (d ~ 0), could not move at all: 3,528
/// vertex halts in the offset stack of three boxes. None when no two bodies touch.
template <class Unpinned, class Held>
std::vector<Found> pair_contacts(const RigidBodies& rigid, std::span<const ContactPair> contacts, size_t nb,
                                 Unpinned unpinned, Held held) {
  std::vector<Found> found;
  std::vector<std::uint8_t> in_pair(nb, 0);
  for (const ContactPair& c : contacts) {
    if (c.neighbours) continue;
    const int na = c.side_a();
    const Index a = side_body(rigid, c, 0, na);
    if (!unpinned(a)) continue;
    const Index b = side_body(rigid, c, na, c.size());
    if (!unpinned(b) || a == b) continue;
    found.push_back({&c, a, b});
    in_pair[static_cast<size_t>(a)] = in_pair[static_cast<size_t>(b)] = 1;
  }
  if (found.empty()) return found;
  for (const ContactPair& c : contacts) {
    if (c.neighbours) continue;
    const int na = c.side_a();
    const Index a = side_body(rigid, c, 0, na), b = side_body(rigid, c, na, c.size());
    if (unpinned(a) && in_pair[static_cast<size_t>(a)] && held(c, na, c.size()))
      found.push_back({&c, a, -1});
    else if (unpinned(b) && in_pair[static_cast<size_t>(b)] && held(c, 0, na))
      found.push_back({&c, b, -1, -1.0});
  }
  return found;
}

}  // namespace

bool RigidBodies::holds(const ContactPair& c, int lo, int hi, std::span<const double> inv_mass) const {
  const Index body = side_body(*this, c, lo, hi);
  if (body >= 0) return bodies_[static_cast<size_t>(body)].pinned;
  if (inv_mass.empty()) return false;
  for (int k = lo; k < hi; ++k)
    if (body_of(c.v[k]) >= 0 || inv_mass[c.v[k]] > 0.0) return false;
  return true;
}

Index RigidBodies::answer_pairs(const Positions& x, const Positions& anchor, std::span<const ContactPair> contacts,
                                const PairResponse& response, std::vector<Vec3>& shift, std::vector<Vec3>& turn,
                                std::vector<double>* repelled, std::vector<std::uint8_t>* answered) const {
  const double rest_overlap = response.rest_overlap;
  if (repelled) repelled->assign(contacts.size(), 0.0);
  if (answered) answered->assign(contacts.size(), 0);
  const size_t nb = bodies_.size();
  shift.assign(nb, Vec3::Zero());
  turn.assign(nb, Vec3::Zero());
  if (nb < 2) return 0;
  auto unpinned = [&](Index b) { return b >= 0 && !bodies_[static_cast<size_t>(b)].pinned; };
  auto held = [&](const ContactPair& c, int lo, int hi) { return holds(c, lo, hi, response.inv_mass); };
  const std::vector<Found> found = pair_contacts(*this, contacts, nb, unpinned, held);
  if (found.empty()) return 0;
  if (answered)
    for (const Found& f : found) (*answered)[static_cast<size_t>(f.c - contacts.data())] = f.b >= 0 ? 1 : 2;
  const std::vector<RigidFrame> frame = frames(x);
  const double delta = response.repulsion_range, slack = std::max(delta, rest_overlap);
  std::vector<PairContact> pairs;
  for (const Found& f : found) {
    const ContactPair& c = *f.c;
    const RigidFrame& fa = frame[static_cast<size_t>(f.a)];
    if (!(fa.inv_mass > 0.0)) continue;
    // A side that cannot move answers nothing: w_B = 0, δ_B = 0.
    const RigidFrame* fb = f.b >= 0 ? &frame[static_cast<size_t>(f.b)] : nullptr;
    if (fb && !(fb->inv_mass > 0.0)) continue;
    const Vec3 n = f.sign * c.n;  // from the held side toward the body when b = -1
    // Closest points at the candidates (w > 0 on A, < 0 on B) and the approach since the anchors.
    // Both impulses act at the points' midpoint: equal and opposite on one point, they keep the
    // angular momentum exactly (n need not be along p_A - p_B once the plane has turned).
    Vec3 mid = Vec3::Zero();
    double approach = 0.0;
    for (int k = 0; k < c.size(); ++k) {
      mid += 0.5 * std::abs(c.w[k]) * x[c.v[k]];
      approach += c.w[k] * c.n.dot(x[c.v[k]] - anchor[c.v[k]]);
    }
    // Only a contact near acting enters the sweeps: one beyond the repulsion's reach by more than
    // `slack` acts only if the others move its bodies that far (the planes hold it then).
    const double gap = c.distance - c.offset + approach;
    if (gap >= delta + slack) continue;
    PairContact pc{f.a,
                   f.b,
                   n,
                   mid - fa.centre,
                   fb ? Vec3(mid - fb->centre) : Vec3::Zero(),
                   gap + (fb ? rest_overlap : 0.0),  // a support closes the whole overlap
                   fa.inverse_mass_at(mid, n) + (fb ? fb->inverse_mass_at(mid, n) : 0.0),
                   0.0,
                   gap,
                   0.0,
                   static_cast<size_t>(f.c - contacts.data())};
    if (pc.w > 0.0) pairs.push_back(pc);
  }
  if (pairs.empty()) return 0;
  // C = base + n·(δ_A(m) - δ_B(m)), δ a body's displacement so far (rotation linearized), m the
  // midpoint; δ_B = 0 for a side that cannot move (b = -1).
  auto moved = [&](const PairContact& p) {
    const size_t a = static_cast<size_t>(p.a);
    Vec3 d = shift[a] + turn[a].cross(p.arm_a);
    if (p.b >= 0) d -= shift[static_cast<size_t>(p.b)] + turn[static_cast<size_t>(p.b)].cross(p.arm_b);
    return p.n.dot(d);
  };
  auto push = [&](const PairContact& p, double dl) {
    // +Δλ n on A, -Δλ n on B, both at the midpoint.
    const RigidFrame& fa = frame[static_cast<size_t>(p.a)];
    shift[static_cast<size_t>(p.a)] += fa.inv_mass * dl * p.n;
    turn[static_cast<size_t>(p.a)] += fa.inv_inertia * p.arm_a.cross(p.n) * dl;
    if (p.b < 0) return;
    const RigidFrame& fb = frame[static_cast<size_t>(p.b)];
    shift[static_cast<size_t>(p.b)] -= fb.inv_mass * dl * p.n;
    turn[static_cast<size_t>(p.b)] -= fb.inv_inertia * p.arm_b.cross(p.n) * dl;
  };
  const double alpha = response.repulsion_compliance;
  // Converged once no overlap is left beyond round-off and no repulsion moves a pair by more
  // than a thousandth of δ in a sweep.
  const double tolerance = 1e-9 * std::max(rest_overlap, 1e-6), settled = 1e-3 * delta;
  Index pushed = 0;
  for (int sweep = 0; sweep < response.sweeps; ++sweep) {
    double worst = 0.0;
    double change = 0.0;
    for (PairContact& p : pairs) {
      const double c = p.base + moved(p);
      const double next = std::max(0.0, p.lambda - c / p.w);
      const double dl = next - p.lambda;
      worst = std::max(worst, -c);
      if (dl != 0.0) {
        p.lambda = next;
        push(p, dl);
      }
      // A side that cannot move leaves the repulsion (and the friction) to the body's pose solve.
      if (!(delta > 0.0) || p.b < 0) continue;
      // The pair's XPBD repulsion of its gap toward δ, both bodies answering.
      const double gap = p.gap + moved(p);
      const double rep = std::max(0.0, p.lambda_r + (delta - gap - alpha * p.lambda_r) / (p.w + alpha));
      const double dr = rep - p.lambda_r;
      if (dr == 0.0) continue;
      p.lambda_r = rep;
      change = std::max(change, std::abs(dr) * p.w);
      push(p, dr);
    }
    if (worst <= tolerance && change <= settled) break;
  }
  for (const PairContact& p : pairs) {
    pushed += p.lambda > 0.0 || p.lambda_r > 0.0;
    if (repelled) (*repelled)[p.contact] = p.lambda + p.lambda_r;
  }
  return pushed;
}

}  // namespace ccfr
