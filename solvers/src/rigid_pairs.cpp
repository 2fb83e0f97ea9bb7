// Inelastic contact between two unpinned rigid bodies (contact.momentum): impulses on both poses.
#include <algorithm>
#include <vector>

#include "ccfr/solvers/rigid_bodies.hpp"

namespace ccfr {

namespace {

/// One contact between two bodies: the arms of its closest points' midpoint about the bodies'
/// centres at the candidates, its generalized inverse mass along n, and its accumulated impulse
/// (kg m).
struct PairContact {
  Index a = -1, b = -1;  ///< the bodies of sides A and B
  Vec3 n = Vec3::Zero();
  Vec3 arm_a = Vec3::Zero(), arm_b = Vec3::Zero();
  double base = 0.0;  ///< C at the candidates before any impulse (m), rest included
  double w = 0.0;     ///< w_A + w_B
  double lambda = 0.0;
};

/// The body holding every vertex of `c` in [lo, hi), or -1 (none, or more than one).
Index side_body(const RigidBodies& rigid, const ContactPair& c, int lo, int hi) {
  const Index body = rigid.body_of(c.v[lo]);
  for (int k = lo + 1; k < hi; ++k)
    if (rigid.body_of(c.v[k]) != body) return -1;
  return body;
}

}  // namespace

Index RigidBodies::answer_pairs(const Positions& x, const Positions& anchor, std::span<const ContactPair> contacts,
                                double rest_overlap, int sweeps, std::vector<Vec3>& shift,
                                std::vector<Vec3>& turn) const {
  const size_t nb = bodies_.size();
  shift.assign(nb, Vec3::Zero());
  turn.assign(nb, Vec3::Zero());
  if (nb < 2) return 0;
  // The contacts between two different bodies first (most scenes have none: no fit is needed).
  struct Found {
    const ContactPair* c;
    Index a, b;
  };
  std::vector<Found> found;
  for (const ContactPair& c : contacts) {
    if (c.neighbours) continue;
    const int na = c.side_a();
    const Index a = side_body(*this, c, 0, na);
    if (a < 0) continue;
    const Index b = side_body(*this, c, na, c.size());
    if (b >= 0 && a != b) found.push_back({&c, a, b});
  }
  if (found.empty()) return 0;
  const std::vector<RigidFrame> frame = frames(x);
  std::vector<PairContact> pairs;
  for (const Found& f : found) {
    const ContactPair& c = *f.c;
    const RigidFrame &fa = frame[static_cast<size_t>(f.a)], &fb = frame[static_cast<size_t>(f.b)];
    if (!(fa.inv_mass > 0.0) || !(fb.inv_mass > 0.0)) continue;  // a pinned body: the planes hold it
    // Closest points at the candidates (w > 0 on A, < 0 on B) and the approach since the anchors.
    // Both impulses act at the points' midpoint: equal and opposite on one point, they keep the
    // angular momentum exactly (n need not be along p_A - p_B once the plane has turned).
    Vec3 mid = Vec3::Zero();
    double approach = 0.0;
    for (int k = 0; k < c.size(); ++k) {
      mid += 0.5 * std::abs(c.w[k]) * x[c.v[k]];
      approach += c.w[k] * c.n.dot(x[c.v[k]] - anchor[c.v[k]]);
    }
    const double base = c.distance - c.offset + approach + rest_overlap;
    PairContact pc{f.a,
                   f.b,
                   c.n,
                   mid - fa.centre,
                   mid - fb.centre,
                   base,
                   fa.inverse_mass_at(mid, c.n) + fb.inverse_mass_at(mid, c.n)};
    if (pc.w > 0.0) pairs.push_back(pc);
  }
  if (pairs.empty()) return 0;
  // C = base + n·(δ_A(m) - δ_B(m)), δ a body's displacement so far (rotation linearized), m the midpoint.
  auto value = [&](const PairContact& p) {
    const size_t a = static_cast<size_t>(p.a), b = static_cast<size_t>(p.b);
    const Vec3 da = shift[a] + turn[a].cross(p.arm_a), db = shift[b] + turn[b].cross(p.arm_b);
    return p.base + p.n.dot(da - db);
  };
  const double tolerance = 1e-9 * std::max(rest_overlap, 1e-6);
  Index pushed = 0;
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    double worst = 0.0;
    for (PairContact& p : pairs) {
      const double c = value(p);
      const double next = std::max(0.0, p.lambda - c / p.w);
      const double dl = next - p.lambda;
      worst = std::max(worst, -c);
      if (dl == 0.0) continue;
      p.lambda = next;
      // +Δλ n on A, -Δλ n on B, both at the midpoint.
      const RigidFrame &fa = frame[static_cast<size_t>(p.a)], &fb = frame[static_cast<size_t>(p.b)];
      shift[static_cast<size_t>(p.a)] += fa.inv_mass * dl * p.n;
      turn[static_cast<size_t>(p.a)] += fa.inv_inertia * p.arm_a.cross(p.n) * dl;
      shift[static_cast<size_t>(p.b)] -= fb.inv_mass * dl * p.n;
      turn[static_cast<size_t>(p.b)] -= fb.inv_inertia * p.arm_b.cross(p.n) * dl;
    }
    if (worst <= tolerance) break;
  }
  for (const PairContact& p : pairs) pushed += p.lambda > 0.0;
  return pushed;
}

}  // namespace ccfr
