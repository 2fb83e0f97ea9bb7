#include "ccfr/solvers/contact_response.hpp"
#include "ccfr/solvers/tethers.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <string>

#include "ccfr/core/buffers.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"

namespace ccfr {

double contact_gap(const ContactPair& c, const Positions& x) {
  Vec3 d = Vec3::Zero();
  for (int k = 0; k < c.size(); ++k) d += c.w[k] * x[c.v[k]];
  return c.n.dot(d) - c.offset;
}

void ContactResponse::prepare_common(std::span<const ContactPair> contacts, const ContactParams& params,
                                     std::span<const Index> row_start, std::span<const Index> slots,
                                     std::span<const double> movable) {
  contacts_ = contacts;
  prepared_repulsion_ = params.repulsion_range > 0.0;
  if (!prepared_repulsion_) return;  // apply() does nothing without a repulsion range
  const double width = params.visibility_width > 0.0 ? params.visibility_width : params.repulsion_range;
  if (row_start.empty())
    visibility_weights(contacts, width, visibility_, visibility_ws_);
  else
    visibility_weights(contacts, row_start, slots, width, visibility_, visibility_ws_, movable);
}

void ContactResponse::prepare(std::span<const ContactPair> contacts, Index num_vertices, const ContactParams& params) {
  prepare_common(contacts, params, {}, {});
  vertex_row_start_.assign(static_cast<size_t>(num_vertices) + 1, 0);
  for (const auto& c : contacts)
    for (int k = 0; k < c.size(); ++k) ++vertex_row_start_[c.v[k] + 1];
  std::partial_sum(vertex_row_start_.begin(), vertex_row_start_.end(), vertex_row_start_.begin());
  vertex_contacts_.resize(static_cast<size_t>(vertex_row_start_.back()));
  std::vector<Index>& cursor = visibility_ws_.cursor;
  cursor.assign(vertex_row_start_.begin(), vertex_row_start_.end() - 1);
  for (Index ci = 0; ci < static_cast<Index>(contacts.size()); ++ci)
    for (int k = 0; k < contacts[ci].size(); ++k) vertex_contacts_[cursor[contacts[ci].v[k]]++] = ci * 4 + k;
  row_start_ = vertex_row_start_;
  slots_ = vertex_contacts_;
}

void ContactResponse::prepare(std::span<const ContactPair> contacts, std::span<const Index> row_start,
                              std::span<const Index> slots, const ContactParams& params,
                              std::span<const double> movable) {
  if (row_start.empty() || static_cast<size_t>(row_start.back()) != slots.size())
    throw Error("ContactResponse::prepare: the incidence has " + std::to_string(slots.size()) +
                " slots, its row starts end at " +
                (row_start.empty() ? std::string("nothing") : std::to_string(row_start.back())));
  prepare_common(contacts, params, row_start, slots, movable);
  row_start_ = row_start;
  slots_ = slots;
}

void ContactResponse::apply(Positions& x, const Positions& x_start, std::span<const double> inv_mass,
                            const ContactParams& p, double dt, std::span<const double> friction_override,
                            std::span<const double> other_inverse_mass, bool record_impulses) {
  const Index n = static_cast<Index>(contacts_.size());
  // With every inverse mass 0 no contact moves anything (each is skipped at Σ wₖ² mₖ⁻¹ = 0).
  if (n == 0 || p.repulsion_range <= 0.0 ||
      std::none_of(inv_mass.begin(), inv_mass.end(), [](double w) { return w > 0.0; })) {
    active_ = 0;
    impulse_.clear();
    return;
  }
  if (!prepared_repulsion_) throw Error("ContactResponse::apply: prepare() had no repulsion range, apply() has one");
  const double alpha_tilde = 1.0 / (p.stiffness * dt * dt);
  // Per active contact: the correction of each of its vertices, computed from the same x (Jacobi),
  // in its block's stage at corr_at_ (-1: inactive). Fixed blocks keep the stages thread-independent.
  const Index blocks = (n + kStageBlock - 1) / kStageBlock;
  if (stage_.size() < static_cast<size_t>(blocks)) stage_.resize(static_cast<size_t>(blocks));
  resize_for_overwrite(corr_at_, static_cast<size_t>(n), spare_corr_at_);  // every entry written below
  parallel_for(
      blocks,
      [&](Index block_begin, Index block_end) {
        for (Index block = block_begin; block < block_end; ++block) {
          std::vector<Vec3>& stage = stage_[static_cast<size_t>(block)];
          stage.clear();
          const Index first = block * kStageBlock, last = std::min(n, first + kStageBlock);
          for (Index ci = first; ci < last; ++ci) {
            corr_at_[static_cast<size_t>(ci)] = -1;
            // The weight first: an occluded contact (most of a pile's) reads no record, no position.
            const double vis = visibility_[ci];
            if (vis <= 1e-12) continue;
            const ContactPair& c = contacts_[ci];
            if (c.neighbours) continue;  // a fine mesh's neighbours: their distance is the material's
            const double gap = contact_gap(c, x);
            if (gap >= p.repulsion_range) continue;
            double wsum = 0.0;
            for (int k = 0; k < c.size(); ++k) wsum += c.w[k] * c.w[k] * inv_mass[c.v[k]];
            if (wsum <= 0.0) continue;
            // A rigid body on the other side takes its share of Δλ in its pose solve: both sides'
            // inverse masses divide the correction, or the pair is pushed apart about twice.
            if (!other_inverse_mass.empty()) wsum += other_inverse_mass[static_cast<size_t>(ci)];
            // Only active contacts have corrections, each of its c.size() slots below (the only
            // ones the gather can name): the (many) contacts beyond δ cost no memory and no read-back.
            corr_at_[static_cast<size_t>(ci)] = static_cast<Index>(stage.size());
            stage.resize(stage.size() + 4);
            Vec3* corr = &stage[stage.size() - 4];
            // Repulsion C = d_c - δ <= 0 with compliance α/w_c (visibility scales the stiffness):
            // Δλ = -C / (Σ w_k² m_k⁻¹ + α̃ / w_c), Δx_k = m_k⁻¹ w_k n Δλ.
            const double dl = -(gap - p.repulsion_range) / (wsum + alpha_tilde / vis);
            for (int k = 0; k < c.size(); ++k) corr[k] = inv_mass[c.v[k]] * c.w[k] * dl * c.n;

            // Friction on the tangential relative motion of the substep (Macklin et al. 2014, Eq. 24).
            double mu_s = p.friction_static, mu_k = p.friction_kinetic;
            if (!friction_override.empty() && friction_override[c.v[0]] >= 0.0) mu_s = mu_k = friction_override[c.v[0]];
            if (mu_s <= 0.0 && mu_k <= 0.0) continue;
            Vec3 rel = Vec3::Zero();
            for (int k = 0; k < c.size(); ++k) rel += c.w[k] * ((x[c.v[k]] + corr[k]) - x_start[c.v[k]]);
            const Vec3 tangential = rel - c.n.dot(rel) * c.n;
            const double tl = tangential.norm();
            if (tl <= 0.0) continue;
            // Coulomb bound on the normal correction this contact applied (relative displacement).
            const double depth = std::max(0.0, dl * wsum);
            const Vec3 remove = tl < mu_s * depth ? tangential : tangential * std::min(mu_k * depth / tl, 1.0);
            for (int k = 0; k < c.size(); ++k) corr[k] -= inv_mass[c.v[k]] * c.w[k] * remove / wsum;
          }
        }
      },
      1);
  active_ = 0;
  for (Index block = 0; block < blocks; ++block)
    active_ += static_cast<Index>(stage_[static_cast<size_t>(block)].size() / 4);
  // Gather: each vertex takes the average of its contacts' corrections.
  const Index gathered = std::min(static_cast<Index>(x.size()), static_cast<Index>(row_start_.size()) - 1);
  const bool reacts = record_impulses && !other_inverse_mass.empty();
  if (reacts) resize_for_overwrite(gathered_, static_cast<size_t>(gathered));  // every entry written below
  parallel_for(
      gathered,
      [&](Index b, Index e) {
        for (Index v = b; v < e; ++v) {
          if (reacts) gathered_[static_cast<size_t>(v)] = 0;
          const Index s = row_start_[v], t = row_start_[v + 1];
          if (s == t || inv_mass[v] == 0.0) continue;
          Vec3 sum = Vec3::Zero();
          int cnt = 0;
          for (Index q = s; q < t; ++q) {
            const Vec3* d_at = applied_correction(slots_[q]);
            if (!d_at) continue;
            const Vec3& d = *d_at;
            if (d.squaredNorm() > 0.0) sum += d, ++cnt;
          }
          if (cnt) x[v] += sum / cnt;
          if (reacts) gathered_[static_cast<size_t>(v)] = cnt;
        }
      },
      4096);
  if (!reacts) {
    impulse_.clear();
    return;
  }
  resize_for_overwrite(impulse_, static_cast<size_t>(n), spare_impulse_);  // every entry written below
  parallel_for(
      n,
      [&](Index b, Index e) {
        for (Index ci = b; ci < e; ++ci) {
          impulse_[static_cast<size_t>(ci)] = Vec3::Zero();
          if (corr_at_[static_cast<size_t>(ci)] < 0 || !(other_inverse_mass[static_cast<size_t>(ci)] > 0.0)) continue;
          const ContactPair& c = contacts_[ci];
          Vec3 j = Vec3::Zero();
          for (int k = 0; k < c.size(); ++k) {
            const Index v = c.v[k];
            if (!(inv_mass[v] > 0.0) || v >= gathered || gathered_[static_cast<size_t>(v)] == 0) continue;
            const Vec3& d = *applied_correction(4 * ci + k);
            if (d.squaredNorm() > 0.0) j += d / (inv_mass[v] * gathered_[static_cast<size_t>(v)]);
          }
          impulse_[static_cast<size_t>(ci)] = j;
        }
      },
      1024);
}

namespace {
/// Approach of vertex k of contact c toward the other side: -n·Δx on side A, n·Δx on side B.
double approach(const ContactPair& c, int k, const Positions& x, const Positions& anchor) {
  const double along = c.n.dot(x[c.v[k]] - anchor[c.v[k]]);
  return k < c.side_a() ? -along : along;
}

/// What the pull-back of one overlapping contact reads and writes.
struct PullBack {
  std::span<const double> inv_mass;  ///< #V
  std::span<const Index> count;      ///< per vertex < nv: its overlapping contacts this sweep
  Index nv = 0;
  double excess = 0.0;        ///< E: the contact's overlap
  double w_o = 0.0;           ///< split inverse mass of an other side that answers in its own solve; 0: none
  Vec3* corr = nullptr;       ///< the contact's 4 correction slots
  double* impulse = nullptr;  ///< the sweep's impulse J on a self-answering side (written only when w_o > 0)
};

/// Barycentric sweeps: the closest points' overlap split in proportion to each vertex's
/// w_k² m_k⁻¹ (its split mass, n_k contacts), the self-answering side taking its w_o share.
void barycentric_pull_back(const ContactPair& c, const PullBack& p) {
  const int nk = c.size();
  double wsum = p.w_o;
  for (int k = 0; k < nk; ++k) {
    const Index v = c.v[k];
    if (v < p.nv && p.inv_mass[v] > 0.0)
      wsum += static_cast<double>(std::max<Index>(1, p.count[v])) * c.w[k] * c.w[k] * p.inv_mass[v];
  }
  if (p.w_o > 0.0 && wsum > 0.0) *p.impulse = p.excess / wsum;
  for (int k = 0; k < nk; ++k) {
    const Index v = c.v[k];
    p.corr[k] = wsum > 0.0 && v < p.nv && p.inv_mass[v] > 0.0
                    ? Vec3((static_cast<double>(p.count[v]) * p.inv_mass[v] * c.w[k] * p.excess / wsum) * c.n)
                    : Vec3::Zero();
  }
}

/// How far the closest points' line may carry a vertex sweep: its impulse moves them apart by at
/// most this many times the contact's overlap E (m / m). Beyond, the vertices that overshoot weigh
/// too little at the closest points and are pulled back themselves (vertex_pull_back).
constexpr double kLineReach = 4.0;

/// Vertex sweeps on the closest points' line: one impulse J along n through the closest points,
/// vertex k moved by β_k J, β_k = n_k m_k⁻¹ |w_k| / Σ_j n_j w_j² m_j⁻¹ (split masses, as in the
/// barycentric sweeps: linear and angular momentum kept), J the least with
/// \f$\max_A(\alpha_k - \beta_k J) + \max_B(\alpha_k - \beta_k J) \le a_A + a_B - E\f$,
/// α_k the approaches. False, nothing written, where a vertex is immovable, the other side answers
/// in its own solve, or J would exceed kLineReach E.
bool line_pull_back(const ContactPair& c, const PullBack& p, const Positions& x, const Positions& anchor) {
  const int na = c.side_a(), nk = c.size();
  if (p.w_o > 0.0) return false;
  double wsum = 0.0;
  for (int k = 0; k < nk; ++k) {
    const Index v = c.v[k];
    if (!(v < p.nv && p.inv_mass[v] > 0.0)) return false;
    wsum += static_cast<double>(std::max<Index>(1, p.count[v])) * c.w[k] * c.w[k] * p.inv_mass[v];
  }
  if (!(wsum > 0.0)) return false;
  double app[4], beta[4];
  for (int k = 0; k < nk; ++k) {
    beta[k] = static_cast<double>(p.count[c.v[k]]) * p.inv_mass[c.v[k]] * std::abs(c.w[k]) / wsum;
    app[k] = approach(c, k, x, anchor);
  }
  // Overlap left at impulse J: convex and non-increasing in J (every β_k >= 0), E at J = 0.
  auto left = [&](double j) {
    double a[2] = {-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
    for (int k = 0; k < nk; ++k) a[k < na ? 0 : 1] = std::max(a[k < na ? 0 : 1], app[k] - beta[k] * j);
    return a[0] + a[1];
  };
  const double allowed = left(0.0) - p.excess;
  double lo = 0.0, hi = kLineReach * p.excess;
  if (left(hi) > allowed) return false;
  for (int it = 0; it < 48; ++it) {
    const double mid = 0.5 * (lo + hi);
    (left(mid) > allowed ? lo : hi) = mid;
  }
  // Side A (w_k > 0) gives way along +n, side B (w_k < 0) along -n.
  for (int k = 0; k < nk; ++k)
    p.corr[k] = Vec3((static_cast<double>(p.count[c.v[k]]) * p.inv_mass[c.v[k]] * c.w[k] * hi / wsum) * c.n);
  return true;
}

/// Vertex sweeps where the closest points' line does not reach: the share s of E that balances
/// the momentum of the two sides' pull-backs, each vertex with its split mass m_k / n_k (an
/// unpinned rigid body on the other side with 1 / w_o at its closest point; a side with an
/// immovable vertex does not give way), then each vertex's pull-back along n.
void vertex_pull_back(const ContactPair& c, const PullBack& p, const Positions& x, const Positions& anchor) {
  if (line_pull_back(c, p, x, anchor)) return;
  const int na = c.side_a(), nk = c.size();
  const double excess = p.excess, w_o = p.w_o;
  double app[4], mass[4], a[2] = {-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  bool fixed[2] = {false, false}, free[2] = {false, false};
  for (int k = 0; k < nk; ++k) {
    const Index v = c.v[k];
    const int side = k < na ? 0 : 1;
    app[k] = approach(c, k, x, anchor);
    a[side] = std::max(a[side], app[k]);
    if (p.inv_mass[v] > 0.0) {
      free[side] = true;
      mass[k] = 1.0 / (p.inv_mass[v] * static_cast<double>(std::max<Index>(1, v < p.nv ? p.count[v] : 1)));
    } else {
      fixed[side] = true;
      mass[k] = 0.0;
    }
  }
  // Momentum of side's pull-back at share t of E (its vertices beyond a_side - t E).
  auto pulled = [&](int side, double t) {
    if (!free[side] && w_o > 0.0) return t * excess / w_o;  // a rigid body answering for itself
    double m = 0.0;
    for (int k = side == 0 ? 0 : na; k < (side == 0 ? na : nk); ++k)
      m += mass[k] * std::max(0.0, app[k] - a[side] + t * excess);
    return m;
  };
  const bool gives[2] = {free[0] && !fixed[0], free[1] && !fixed[1]};
  auto answers = [&](int side) { return gives[side] || (!free[side] && w_o > 0.0); };
  double share = gives[0] ? 1.0 : 0.0;  // one side gives way, the other cannot
  if (!gives[0] && !gives[1]) {
    share = -1.0;  // neither can
  } else if (answers(0) && answers(1)) {
    double lo = 0.0, hi = 1.0;  // pulled(A, s) - pulled(B, 1 - s) rises from <= 0 to >= 0
    for (int it = 0; it < 48; ++it) {
      const double mid = 0.5 * (lo + hi);
      (pulled(0, mid) < pulled(1, 1.0 - mid) ? lo : hi) = mid;
    }
    share = 0.5 * (lo + hi);
    for (int side = 0; side < 2; ++side)
      if (!free[side] && w_o > 0.0) *p.impulse = (side == 0 ? share : 1.0 - share) * excess / w_o;
  }
  for (int k = 0; k < nk; ++k) {
    const int side = k < na ? 0 : 1;
    const double t = side == 0 ? share : 1.0 - share;
    const double back = share < 0.0 || !(p.inv_mass[c.v[k]] > 0.0) ? 0.0 : std::max(0.0, app[k] - a[side] + t * excess);
    // Side A gives way along +n, side B along -n.
    p.corr[k] = (side == 0 ? back : -back) * c.n;
  }
}
}  // namespace

ContactResponse::Measured ContactResponse::measure(Index ci, const Positions& x, const Positions& anchor,
                                                   std::span<const double> inv_mass, double rest_overlap) const {
  const ContactPair& c = contacts_[ci];
  Measured m;
  if (c.neighbours) return m;
  double a[2] = {-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  Vec3 at = Vec3::Zero();
  for (int k = 0; k < c.size(); ++k) {
    a[k < c.side_a() ? 0 : 1] = std::max(a[k < c.side_a() ? 0 : 1], approach(c, k, x, anchor));
    m.moves = m.moves || inv_mass[c.v[k]] > 0.0;
    at += c.w[k] * (x[c.v[k]] - anchor[c.v[k]]);
  }
  // Barycentric sweeps: the closest points' approach; then every vertex's. The first
  // `rest_overlap` of it is resting contact, left to the planes.
  const double given = separate_given_.empty() ? 0.0 : separate_given_[static_cast<size_t>(ci)];
  m.barycentric = -(c.distance - c.offset + c.n.dot(at)) - given - rest_overlap;
  m.vertex = a[0] + a[1] - (c.distance - c.offset) - given - rest_overlap;
  return m;
}

double ContactResponse::overlap(const Measured& m, Index ci, bool barycentric) const {
  // Overlaps below 1e-9 of the offset are rounding, left to the planes too; so is a contact that cannot move.
  const double e_c = barycentric ? m.barycentric : m.vertex;
  return m.moves && e_c > 1e-9 * contacts_[ci].offset ? e_c : 0.0;
}

void ContactResponse::build_touch(Index nv) {
  // Every contact, not the caller's CSR: that lists only the contacts that gave a vertex a plane.
  const Index n = static_cast<Index>(contacts_.size());
  touch_start_.assign(static_cast<size_t>(nv) + 1, 0);
  for (const ContactPair& c : contacts_)
    for (int k = 0; k < c.size(); ++k)
      if (c.v[k] < nv) ++touch_start_[c.v[k] + 1];
  std::partial_sum(touch_start_.begin(), touch_start_.end(), touch_start_.begin());
  touch_.resize(static_cast<size_t>(touch_start_.back()));
  touch_growth_.resize(touch_.size());
  std::vector<Index> cursor(touch_start_.begin(), touch_start_.end() - 1);
  for (Index ci = 0; ci < n; ++ci) {
    const ContactPair& c = contacts_[ci];
    for (int k = 0; k < c.size(); ++k) {
      if (c.v[k] >= nv) continue;
      // A step s of vertex k adds at most max(1, |w_k|) max(0, ±n·s) to either overlap measure: E is
      // the weighted sum of the approaches, or one side's largest plus the other's.
      const Index q = cursor[c.v[k]]++;
      touch_[q] = ci;
      touch_growth_[static_cast<size_t>(q)] = std::max(1.0, std::abs(c.w[k])) * (k < c.side_a() ? Vec3(-c.n) : c.n);
    }
  }
  listed_.assign(static_cast<size_t>(n), 0);
  touch_built_ = true;
}

Index ContactResponse::mark_overlaps(const Positions& x, const Positions& anchor, std::span<const double> inv_mass,
                                     bool barycentric, double rest_overlap, Listing listing) {
  const Index nc = static_cast<Index>(contacts_.size());
  if (listing != Listing::every) {
    // Each contact's bounds grow by what the last sweep's steps could add to its overlap; a contact
    // around a moved vertex is measured again only while its bound leaves it overlapping (the
    // overlaps of the others are at most their bounds, so at most 0).
    const Index nv = static_cast<Index>(separate_moved_.size());
    if (!touch_built_) build_touch(nv);
    const bool by_bound = listing == Listing::by_bound;
    for (const Index ci : overlapping_) listed_[static_cast<size_t>(ci)] = 1;
    for (const Index v : touched_) {  // the last sweep's: every vertex it moved is among them
      if (!steps_pending_ || !separate_moved_[v]) continue;
      const Vec3& step = separate_step_[static_cast<size_t>(v)];
      for (Index q = touch_start_[v]; q < touch_start_[v + 1]; ++q) {
        const auto ci = static_cast<size_t>(touch_[q]);
        OverlapBound& bound = bounds_[ci];
        const double grown = std::max(0.0, touch_growth_[static_cast<size_t>(q)].dot(step));
        bound.barycentric += grown;
        bound.vertex += grown;
        if (!by_bound && !listed_[ci] && (barycentric ? bound.barycentric : bound.vertex) > 0.0)
          listed_[ci] = 1, overlapping_.push_back(touch_[q]);
      }
    }
    steps_pending_ = false;
    if (by_bound) {
      // The first vertex sweep, in contact order: every contact its bound leaves overlapping, and
      // those the last sweep found overlapping (their E was barycentric, at most the vertex one).
      overlapping_.clear();
      for (Index ci = 0; ci < nc; ++ci) {
        const auto c = static_cast<size_t>(ci);
        if (bounds_[c].vertex > 0.0 || listed_[c] || (bodies_moved_ && is_body_contact_[c])) overlapping_.push_back(ci);
      }
    } else if (bodies_moved_) {
      // A body that moved changed the overlap of every one of its contacts.
      for (const Index ci : body_contacts_)
        if (!listed_[static_cast<size_t>(ci)]) listed_[static_cast<size_t>(ci)] = 1, overlapping_.push_back(ci);
    }
  }
  const bool every = listing == Listing::every;
  const Index n = every ? nc : static_cast<Index>(overlapping_.size());
  parallel_for(
      n,
      [&](Index b, Index e) {
        for (Index i = b; i < e; ++i) {
          const Index ci = every ? i : overlapping_[i];
          const Measured m = measure(ci, x, anchor, inv_mass, rest_overlap);
          bounds_[static_cast<size_t>(ci)] = {m.barycentric, m.vertex};
          separate_dl_[static_cast<size_t>(ci)] = overlap(m, ci, barycentric);
        }
      },
      2048);
  // The new overlapping list, in contact order for a full sweep, in list order otherwise.
  std::vector<Index> next;
  next.reserve(overlapping_.size());
  for (Index i = 0; i < n; ++i) {
    const Index ci = every ? i : overlapping_[i];
    if (!every) listed_[static_cast<size_t>(ci)] = 0;
    if (separate_dl_[static_cast<size_t>(ci)] != 0.0) next.push_back(ci);
  }
  overlapping_.swap(next);
  return static_cast<Index>(overlapping_.size());
}

void ContactResponse::count_overlaps(Index nv, std::span<const double> inv_mass) {
  touched_.clear();
  for (const Index ci : overlapping_) {
    const ContactPair& c = contacts_[ci];
    for (int k = 0; k < c.size(); ++k) {
      const Index v = c.v[k];
      if (v < nv && !touched_mark_[v]) touched_mark_[v] = 1, touched_.push_back(v);
    }
  }
  std::sort(touched_.begin(), touched_.end());
  for (const Index v : touched_) touched_mark_[v] = 0;
  parallel_for(
      static_cast<Index>(touched_.size()),
      [&](Index b, Index e) {
        for (Index i = b; i < e; ++i) {
          const Index v = touched_[i];
          Index cnt = 0;
          if (inv_mass[v] > 0.0)
            for (Index q = row_start_[v]; q < row_start_[v + 1]; ++q) cnt += separate_dl_[slots_[q] / 4] != 0.0;
          separate_count_[v] = cnt;
        }
      },
      4096);
}

void ContactResponse::pull_back(const Positions& x, const Positions& anchor, std::span<const double> inv_mass, Index nv,
                                bool barycentric, const AnsweringBodies* bodies) {
  resize_for_overwrite(corr_, overlapping_.size() * 4);  // every slot move_by_mean reads is written below
  parallel_for(
      static_cast<Index>(overlapping_.size()),
      [&](Index b, Index e) {
        for (Index i = b; i < e; ++i) {
          const Index ci = overlapping_[i];
          PullBack p;
          p.inv_mass = inv_mass;
          p.count = separate_count_;
          p.nv = nv;
          p.excess = separate_dl_[static_cast<size_t>(ci)];
          corr_at_[static_cast<size_t>(ci)] = i;
          p.corr = &corr_[static_cast<size_t>(i) * 4];
          if (bodies) {
            const Index body = bodies->body[static_cast<size_t>(ci)];
            // Split like a vertex, its turn by the row sums of its coupling (see body_split_).
            if (body >= 0 && bodies->inverse_mass_at[static_cast<size_t>(ci)] > 0.0) {
              const auto bi = static_cast<size_t>(body);
              const double turn =
                  std::max(0.0, bodies->inverse_mass_at[static_cast<size_t>(ci)] - bodies->inv_mass[bi]);
              p.w_o = static_cast<double>(body_count_[bi]) * bodies->inv_mass[bi] + std::sqrt(turn) * body_split_[bi];
            }
            separate_impulse_[static_cast<size_t>(ci)] = 0.0;
            p.impulse = &separate_impulse_[static_cast<size_t>(ci)];
          }
          if (barycentric)
            barycentric_pull_back(contacts_[ci], p);
          else
            vertex_pull_back(contacts_[ci], p, x, anchor);
        }
      },
      2048);
}

void ContactResponse::move_by_mean(Positions& x, std::span<const double> inv_mass, const Tethers* tethers,
                                   std::span<const double> uncapped) {
  parallel_for(
      static_cast<Index>(touched_.size()),
      [&](Index b, Index e) {
        for (Index i = b; i < e; ++i) {
          const Index v = touched_[i];
          separate_moved_[v] = 0;
          if (!(inv_mass[v] > 0.0) || separate_count_[v] == 0) continue;
          Vec3 sum = Vec3::Zero();
          for (Index q = row_start_[v]; q < row_start_[v + 1]; ++q)
            if (separate_dl_[slots_[q] / 4] != 0.0) sum += corr_[4 * corr_at_[slots_[q] / 4] + slots_[q] % 4];
          const Vec3 before = x[v];
          x[v] += sum / static_cast<double>(separate_count_[v]);
          separate_step_[static_cast<size_t>(v)] = x[v] - before;
          if (tethers) {
            // A vertex put back on its tethers gives way in later sweeps by the share of this push
            // they let through (a swing along one sphere keeps most); one back inside, freely.
            const Vec3 step = sum / static_cast<double>(separate_count_[v]);
            capped_mass_[v] = tethers->cap(x, v) ? tethers->share(x, v, step) * uncapped[v] : uncapped[v];
          }
          separate_moved_[v] = x[v] != before;
        }
      },
      4096);
}

bool ContactResponse::move_bodies(const AnsweringBodies& bodies) {
  bool moved = false;
  for (const Index ci : overlapping_) {  // in list order: the sums do not depend on the threads
    const double j = separate_impulse_[static_cast<size_t>(ci)];
    const Index b = bodies.body[static_cast<size_t>(ci)];
    if (j == 0.0 || b < 0) continue;
    const Vec3 impulse = j * bodies.away[static_cast<size_t>(ci)];
    body_push_[static_cast<size_t>(b)] += impulse;
    body_twist_[static_cast<size_t>(b)] += bodies.arm[static_cast<size_t>(ci)].cross(impulse);
    moved = true;
  }
  if (!moved) return false;
  parallel_for(
      static_cast<Index>(body_contacts_.size()),
      [&](Index lo, Index hi) {
        for (Index i = lo; i < hi; ++i) {
          const auto ci = static_cast<size_t>(body_contacts_[static_cast<size_t>(i)]);
          const auto b = static_cast<size_t>(bodies.body[ci]);
          const Vec3 shift =
              bodies.inv_mass[b] * body_push_[b] + (bodies.inv_inertia[b] * body_twist_[b]).cross(bodies.arm[ci]);
          separate_given_[ci] = bodies.away[ci].dot(shift);
        }
      },
      1024);
  return true;
}

Index ContactResponse::separate(Positions& x, const Positions& anchor, std::span<const double> inv_mass, int sweeps,
                                double rest_overlap, const AnsweringBodies* bodies, const Tethers* tethers) {
  const Index n = static_cast<Index>(contacts_.size());
  // body_impulse() and given are this call's.
  separate_given_.clear();
  body_push_.clear();
  body_twist_.clear();
  body_contacts_.clear();
  bodies_moved_ = false;
  if (bodies) {
    const auto nc = static_cast<size_t>(n);
    if (bodies->body.size() != nc || bodies->inverse_mass_at.size() != nc || bodies->arm.size() != nc ||
        bodies->away.size() != nc || bodies->inv_inertia.size() != bodies->inv_mass.size())
      throw Error("ContactResponse::separate: the answering bodies do not match the " + std::to_string(n) +
                  " contacts or their own count");
    if (bodies->inv_mass.empty()) bodies = nullptr;
  }
  if (bodies) {
    body_push_.assign(bodies->inv_mass.size(), Vec3::Zero());
    body_twist_ = body_push_;
  }
  if (n == 0 || sweeps <= 0) return 0;
  if (row_start_.empty()) throw Error("ContactResponse::separate: called before prepare()");
  const Index nv = std::min(static_cast<Index>(x.size()), static_cast<Index>(row_start_.size()) - 1);
  separate_dl_.resize(static_cast<size_t>(n));
  separate_count_.resize(static_cast<size_t>(nv));
  separate_moved_.assign(static_cast<size_t>(nv), 0);
  separate_step_.resize(static_cast<size_t>(nv));
  bounds_.resize(static_cast<size_t>(n));
  touched_mark_.assign(static_cast<size_t>(nv), 0);
  touch_built_ = false;
  steps_pending_ = false;
  overlapping_.clear();
  touched_.clear();
  corr_at_.resize(static_cast<size_t>(n));
  if (bodies) {
    // Per contact: how far its answering body (not moved here) has given way at it so far, so that
    // later sweeps leave the body its part instead of handing it to the other side.
    separate_given_.assign(static_cast<size_t>(n), 0.0);
    separate_impulse_.assign(static_cast<size_t>(n), 0.0);
    body_count_.assign(bodies->inv_mass.size(), 0);
    body_split_.assign(bodies->inv_mass.size(), 0.0);
    is_body_contact_.assign(static_cast<size_t>(n), 0);
    for (Index ci = 0; ci < n; ++ci)
      if (bodies->body[static_cast<size_t>(ci)] >= 0 && bodies->inverse_mass_at[static_cast<size_t>(ci)] > 0.0)
        body_contacts_.push_back(ci), is_body_contact_[static_cast<size_t>(ci)] = 1;
  }
  const std::span<const double> uncapped = inv_mass;
  if (tethers) {
    capped_mass_.assign(inv_mass.begin(), inv_mass.end());
    inv_mass = capped_mass_;
  }
  Index most = 0;
  const int first_vertex_sweep = sweeps * 3 / 4;
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    const bool barycentric = sweep < first_vertex_sweep;
    // Overlapping contacts of this sweep: separate_dl_ holds E (0: none). The first sweep measures
    // every contact, the first vertex sweep those its bounds leave overlapping, later ones those
    // that overlapped or whose vertices moved.
    const Listing listing = sweep == 0 || measure_every_sweep_ ? Listing::every
                            : sweep == first_vertex_sweep      ? Listing::by_bound
                                                               : Listing::around_moved;
    const Index closed = mark_overlaps(x, anchor, inv_mass, barycentric, rest_overlap, listing);
    most = std::max(most, closed);
    if (closed == 0) {
      if (!barycentric) break;
      sweep = first_vertex_sweep - 1;  // the closest points are apart: on to every vertex's approach
      continue;
    }
    // Active contacts per vertex, read through the vertex -> contact-slot incidence.
    count_overlaps(nv, inv_mass);
    if (bodies) {
      std::fill(body_count_.begin(), body_count_.end(), 0);
      std::fill(body_split_.begin(), body_split_.end(), 0.0);
      for (const Index ci : overlapping_) {
        const Index b = bodies->body[static_cast<size_t>(ci)];
        if (b < 0 || !(bodies->inverse_mass_at[static_cast<size_t>(ci)] > 0.0)) continue;
        ++body_count_[static_cast<size_t>(b)];
        body_split_[static_cast<size_t>(b)] += std::sqrt(
            std::max(0.0, bodies->inverse_mass_at[static_cast<size_t>(ci)] - bodies->inv_mass[static_cast<size_t>(b)]));
      }
    }
    // Per contact: each vertex's pull-back (barycentric_pull_back, vertex_pull_back).
    pull_back(x, anchor, inv_mass, nv, barycentric, bodies);
    // Each vertex moves by the mean of its contacts' pull-backs: with split masses every contact
    // is balanced, so Σ_k (m_k / n_k) Σ_c Δx_k^c = 0 stays after the mean.
    move_by_mean(x, inv_mass, tethers, uncapped);
    steps_pending_ = true;
    if (bodies) bodies_moved_ = move_bodies(*bodies);
  }
  return most;
}

}  // namespace ccfr
