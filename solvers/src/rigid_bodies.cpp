#include "ccfr/solvers/rigid_bodies.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <iterator>

#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry/mass_properties.hpp"
#include "ccfr/solvers/polar_decomposition.hpp"

namespace ccfr {

namespace {

/// A constraint value below this counts as outside (the recount's tolerance).
constexpr double kOutside = -1e-9;
/// Projected Gauss-Seidel sweeps of a body's pose solve.
constexpr int kPoseSweeps = 32;
/// Sweeps a body with acting contacts runs at least.
constexpr int kMinPoseSweeps = 4;
/// The pose solve aims this fraction of r inside every half-space, so that the exact check of the
/// rigid pose (the exact rotation, not its linearization) passes.
constexpr double kMarginOfBound = 1e-4;
/// How far (a fraction of r) beyond acting a plane joins a pose solve's live contacts. A sweep
/// costs the live contacts, a rebuild every plane of the body: a bunny in a pile has ~300k planes,
/// and at 0.25 r 140k of them were live.
constexpr double kLiveSlack = 0.05;
/// Halvings of the line search after the linear-blend bound.
constexpr int kLineSearchHalvings = 12;

struct Pose {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  Vec3 c = Vec3::Zero();
};

/// Best rigid fit (weighted centre, polar rotation of A_pq; Müller et al. 2005). A core of mass
/// `core` at `core_at` (the centre of the pose the corrections started from) joins the centre only:
/// corrections Δᵢ then move the centre by Σ mᵢΔᵢ / (Σ mᵢ + core) and turn the body by
/// I⁻¹ Σ qᵢ × mᵢΔᵢ to first order, I = tr(S) 1 - S, S = Σ mᵢ qᵢqᵢᵀ: a rigid body's impulse response.
Pose fit(std::span<const Vec3> x, std::span<const Vec3> rest, std::span<const double> m, double core = 0.0,
         const Vec3& core_at = Vec3::Zero()) {
  double total = core;
  Vec3 c = core * core_at;
  for (size_t i = 0; i < x.size(); ++i) {
    total += m[i];
    c += m[i] * x[i];
  }
  c /= total;
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < x.size(); ++i) a.noalias() += m[i] * (x[i] - c) * rest[i].transpose();
  Pose p;
  p.c = c;
  p.q = Eigen::Quaterniond(xpbd::polar_rotation(a));
  p.q.normalize();
  return p;
}

}  // namespace

RigidBodies::RigidBodies(const Topology& topo, const SimState& state, const SimulationParams* params) {
  const bool with_cores = params && params->objects.size() == topo.objects.size();
  for (size_t oi = 0; oi < topo.objects.size(); ++oi) {
    const auto& o = topo.objects[oi];
    if (o.kind != ObjectKind::rigid || o.num_vertices() == 0) continue;
    Body b;
    b.begin = o.vertex_begin;
    b.end = o.vertex_end;
    double max_mass = 0.0;
    for (Index v = b.begin; v < b.end; ++v) {
      b.kinematic.push_back(!(state.inv_mass[v] > 0.0));
      if (state.inv_mass[v] > 0.0)
        max_mass = std::max(max_mass, 1.0 / state.inv_mass[v]);
      else
        b.pinned = true;
    }
    const double kinematic_weight = max_mass > 0.0 ? 1e9 * max_mass : 1.0;
    double total = 0.0;
    Vec3 centre = Vec3::Zero();
    for (Index v = b.begin; v < b.end; ++v) {
      const double m = state.inv_mass[v] > 0.0 ? 1.0 / state.inv_mass[v] : kinematic_weight;
      b.weight.push_back(m);
      total += m;
      centre += m * state.rest[v];
    }
    centre /= total;
    Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
    for (Index v = b.begin; v < b.end; ++v) {
      b.rest.push_back(state.rest[v] - centre);
      b.extent = std::max(b.extent, b.rest.back().norm());
    }
    b.mass = total;
    for (size_t i = 0; i < b.rest.size(); ++i) second.noalias() += b.weight[i] * b.rest[i] * b.rest[i].transpose();
    // The vertices' inertia about the centre, I = tr(S) 1 - S: with the loader's moment-matched masses
    // the solid's (the core adds none). Inverted on its range: a rod or a single vertex does not
    // turn about the axes it has no extent across, and those turns move none of its vertices.
    const Eigen::Matrix3d inertia = second.trace() * Eigen::Matrix3d::Identity() - second;
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(inertia);
    const double top = eig.eigenvalues().cwiseAbs().maxCoeff();
    Vec3 inv = Vec3::Zero();
    for (int k = 0; k < 3; ++k)
      if (eig.eigenvalues()[k] > 1e-12 * top) inv[k] = 1.0 / eig.eigenvalues()[k];
    b.inv_inertia = eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose();
    if (params) {
      const MaterialParams& mat =
          params->objects.size() == topo.objects.size() ? params->objects[oi].material : MaterialParams{};
      b.mu_s = mat.friction >= 0.0 ? mat.friction : params->contact.friction_static;
      b.mu_k = mat.friction >= 0.0 ? mat.friction : params->contact.friction_kinetic;
    }
    if (with_cores && !b.pinned) {
      std::vector<Vec3i> faces;
      for (Index f = o.face_begin; f < o.face_end; ++f) faces.push_back(topo.faces[f] - Vec3i::Constant(b.begin));
      const double solid =
          params->objects[oi].material.density *
          solid_mass_properties(std::span<const Vec3>(state.rest.data() + b.begin, b.rest.size()), faces).volume;
      if (solid > total * (1.0 + 1e-12)) b.core = solid - total;
    }
    bodies_.push_back(std::move(b));
  }
}

std::vector<Vec3> RigidBodies::predicted_cores(const SimState& state, double dt, const Vec3& gravity) const {
  std::vector<Vec3> out(bodies_.size(), Vec3::Zero());
  for (size_t bi = 0; bi < bodies_.size(); ++bi) {
    const Body& b = bodies_[bi];
    double total = 0.0;
    Vec3 c = Vec3::Zero(), v = Vec3::Zero();
    for (size_t i = 0; i < b.rest.size(); ++i) {
      total += b.weight[i];
      c += b.weight[i] * state.x[b.begin + static_cast<Index>(i)];
      v += b.weight[i] * state.v[b.begin + static_cast<Index>(i)];
    }
    // The weighted centre is the solid's centre of mass, and Σ mᵢvᵢ / Σ mᵢ its velocity.
    out[bi] = (c + dt * v) / total + gravity * dt * dt;
  }
  return out;
}

void RigidBodies::mask_free(std::vector<double>& inv_mass) const {
  for (const Body& b : bodies_)
    if (!b.pinned) std::fill(inv_mass.begin() + b.begin, inv_mass.begin() + b.end, 0.0);
}

namespace {

Eigen::Quaterniond rotated(const Eigen::Quaterniond& q, const Vec3& dtheta) {
  // q + ½ (Δθ, 0) q, normalized (Müller et al. 2020, Eq. 8-9).
  Eigen::Quaterniond d(0.0, dtheta.x(), dtheta.y(), dtheta.z());
  d = d * q;
  Eigen::Quaterniond out(q.w() + 0.5 * d.w(), q.x() + 0.5 * d.x(), q.y() + 0.5 * d.y(), q.z() + 0.5 * d.z());
  out.normalize();
  return out;
}

/// The angle of the rotation taking `from` to `to`: no point at distance ρ from the centre moves
/// by more than ρ times it.
double angle_between(const Eigen::Quaterniond& from, const Eigen::Quaterniond& to) {
  const Eigen::Quaterniond d = to * from.conjugate();
  return 2.0 * std::atan2(d.vec().norm(), std::abs(d.w()));
}

/// The pair data of plane q: asked of the caller, or read from its per-plane spans.
RigidPlaneContact pair_of(const RigidContactOptions& options, Index q) {
  if (options.plane_contact) return options.plane_contact(q);
  const size_t s = static_cast<size_t>(q);
  RigidPlaneContact p;
  p.repel = options.repulsion_target.empty() ? options.repulsion_range : options.repulsion_target[s];
  p.other_w = options.repulsion_other.empty() ? 0.0 : options.repulsion_other[s];
  p.other_motion = options.other_motion.empty() ? Vec3::Zero() : options.other_motion[s];
  p.other_wt = options.friction_other.empty() ? 0.0 : options.friction_other[s];
  return p;
}

}  // namespace

/// One body's placement in one enforce() pass. Its contacts are resolved in the body's pose space
/// (Müller et al. 2020, positional constraints with generalized inverse masses): projected
/// Gauss-Seidel on the pose's kinetic metric, rotation linearized about the current pose and
/// re-linearized after every correction, the inverse inertia once per sweep. A pose the exact
/// check rejects falls back to a line search from the anchor pose, or halts the body there.
class RigidBodies::PoseSolver {
 public:
  /// `mass`: the vertices' mass plus the core (kg). Lengths are in the units of the positions;
  /// `own_bound` (at most `step_bound`) bounds this body's steps, `step_bound` sets the margins.
  PoseSolver(const Body& b, Workspace& ws, const Positions& anchor, const RegionSet& regions,
             const RigidContactOptions& options, double step_bound, double own_bound, double mass)
      : b_(b),
        ws_(ws),
        anchor_(anchor),
        regions_(regions),
        options_(options),
        step_bound_(own_bound),
        mass_(mass),
        n_(b.rest.size()),
        q_begin_(regions.row_start[b.begin]),
        q_end_(regions.row_start[b.end]),
        margin_(kMarginOfBound * step_bound),
        slack_(kLiveSlack * step_bound) {}

  /// A pinned body: the pins decide the pose (`target`); only the dynamic vertices move.
  void follow_pins(const Pose& target, std::span<Vec3> xb) {
    place(target, ws_.y);
    for (size_t i = 0; i < n_; ++i)
      if (!b_.kinematic[i]) xb[i] = ws_.y[i];
  }

  /// An unpinned body from its unconstrained fit `target`: writes its vertices to `xb`.
  void solve(const Pose& target, double advance_tolerance, std::span<Vec3> xb, RigidEnforceStats& st) {
    // The contacts: the half-spaces of the body's vertices, recorded (with their pair data
    // and multipliers) only once they come within reach of acting: in a pile most of a
    // body's planes never do, and copying them all each pass cost more than the sweeps.
    ws_.contacts.clear();
    if (ws_.slot.size() < static_cast<size_t>(q_end_ - q_begin_))
      ws_.slot.resize(static_cast<size_t>(q_end_ - q_begin_), -1);
    std::vector<Vec3>& y = ws_.y;
    place(target, y);
    for (size_t i = 0; i < n_; ++i) {
      const Index v = b_.begin + static_cast<Index>(i);
      if (regions_.count(v) > 0 && regions_.falls_below(v, anchor_[v], y[i], 0.0)) ++st.vertices_violated;
    }
    pose_ = target;
    converged_ = q_end_ == q_begin_;
    if (!converged_) rebuild_live();
    pose_sweeps();
    translation_sweeps();
    for (const PoseContact& c : ws_.contacts) ws_.slot[static_cast<size_t>(c.q - q_begin_)] = -1;
    place(pose_, y);
    const bool regions_ok = regions_hold(y);
    if (regions_ok && longest_step(y) <= step_bound_ * (1.0 + 1e-12)) {
      std::copy(y.begin(), y.end(), xb.begin());
      return;
    }
    // The line search runs toward the pose solve's result: when the sweeps left a small
    // violation, a step short of it by about that fraction is admissible (toward the
    // unconstrained pose, the violated contacts stop it near the anchor and the body halts).
    line_search(pose_, regions_ok, advance_tolerance, xb, st);
  }

 private:
  void place(const Pose& p, std::vector<Vec3>& out) const {
    const Eigen::Matrix3d r = p.q.toRotationMatrix();
    out.resize(n_);
    for (size_t i = 0; i < n_; ++i) out[i] = r * b_.rest[i] + p.c;
  }
  bool regions_hold(const std::vector<Vec3>& p) const {
    for (size_t i = 0; i < n_; ++i) {
      const Index v = b_.begin + static_cast<Index>(i);
      if (regions_.falls_below(v, anchor_[v], p[i], kOutside)) return false;
    }
    return true;
  }
  double longest_step(const std::vector<Vec3>& p) const {
    double l = 0.0;
    for (size_t i = 0; i < n_; ++i) l = std::max(l, (p[i] - anchor_[b_.begin + static_cast<Index>(i)]).norm());
    return l;
  }
  /// Inside every region and within the step bound of the anchor.
  bool admissible(const std::vector<Vec3>& p) const {
    return regions_hold(p) && longest_step(p) <= step_bound_ * (1.0 + 1e-12);
  }

  // What the pose solve aims at per half-space: the margin, but no more than the anchor's own
  // value d. A body squeezed between contacts with d ~ 0 on opposite sides (a slab under a
  // box on a floor, the middle body of a pile) cannot clear the margin on both, although sliding
  // along both planes (value d) or staying put is admissible. Accepted once every value is within
  // half its aim (or, for an aim <= 0, a tenth of the recount's tolerance below it); the exact
  // check follows anyway.
  double aim_of(const HalfSpace& h) const { return std::min(margin_, h.d); }
  double accept_of(const HalfSpace& h) const {
    const double a = aim_of(h);
    return a > 0.0 ? 0.5 * a : a + 0.1 * kOutside;
  }
  double aim(const PoseContact& c) const { return aim_of(c.h); }
  double accept(const PoseContact& c) const { return accept_of(c.h); }

  // Most half-spaces of a resting body are far from acting: a contact does nothing in a
  // sweep while its value clears both the margin and its repulsion target and it carries no
  // multiplier. The sweeps visit only the live ones: those within `slack` of acting when the
  // list was built (against δ, which bounds every repulsion target). While the pose has
  // moved no point by more than slack since (the centre's move plus the turn's angle times
  // the extent), the others cannot act; past it the list is rebuilt, and a sweep that
  // crossed it does not count as converged.
  double reach_of(const HalfSpace& h) const {
    return options_.repulsion_range > 0.0 ? std::max(aim_of(h), options_.repulsion_range) : aim_of(h);
  }
  double threshold(const PoseContact& c) const {
    return options_.repulsion_range > 0.0 ? std::max(aim(c), c.pair.repel) : aim(c);
  }
  double moved_since_build() const {
    return (pose_.c - built_.c).norm() + angle_between(built_.q, pose_.q) * b_.extent;
  }
  void rebuild_live() {
    const Eigen::Matrix3d r = pose_.q.toRotationMatrix();
    std::vector<PoseContact>& contacts = ws_.contacts;
    ws_.live.clear();
    for (size_t i = 0; i < n_; ++i) {
      const Index v = b_.begin + static_cast<Index>(i);
      const Index q0 = regions_.row_start[v], q1 = regions_.row_start[v + 1];
      if (q0 == q1) continue;
      const Vec3 at = r * b_.rest[i] + pose_.c;
      for (Index q = q0; q < q1; ++q) {
        const HalfSpace h = regions_.plane(q);
        Index& s = ws_.slot[static_cast<size_t>(q - q_begin_)];
        const double value = h.value(anchor_[v], at);
        // δ bounds every repulsion target: a plane beyond it needs no pair data; nor does
        // one beyond its own target (cheap to ask), which most of those within δ are.
        if (s < 0 && value > reach_of(h) + slack_) continue;
        if (s < 0 && options_.plane_repel && options_.repulsion_range > 0.0 &&
            value > std::max(aim_of(h), options_.plane_repel(q)) + slack_)
          continue;
        if (s < 0) {
          s = static_cast<Index>(contacts.size());
          contacts.push_back({static_cast<Index>(i), q, h, pair_of(options_, q)});
        }
        const PoseContact& c = contacts[static_cast<size_t>(s)];
        if (value <= threshold(c) + slack_ || c.lambda_n != 0.0 || c.lambda_r != 0.0 ||
            c.lambda_t.squaredNorm() != 0.0 || c.pair.pressed > 0.0)
          ws_.live.push_back(s);
      }
    }
    built_ = pose_;
  }

  /// One impulse on the pose: the centre moves by dc, the body turns by dtheta (radians).
  void apply(const Vec3& dc, const Vec3& dtheta) {
    pose_.c += dc;
    pose_.q = rotated(pose_.q, dtheta);
  }

  /// Projected Gauss-Seidel over the live contacts until every value is accepted.
  void pose_sweeps() {
    for (int sweep = 0; sweep < kPoseSweeps && !converged_; ++sweep) {
      if (sweep > 0 && moved_since_build() > slack_) rebuild_live();
      const Eigen::Matrix3d r = pose_.q.toRotationMatrix();
      const Eigen::Matrix3d inv_inertia = r * b_.inv_inertia * r.transpose();
      double worst = 0.0;
      for (const Index k : ws_.live) worst = std::min(worst, visit(ws_.contacts[static_cast<size_t>(k)], inv_inertia));
      // Friction and repulsion need a few sweeps to settle among the contacts even when the
      // hard constraints hold from the start.
      bool acting = false;
      for (const Index k : ws_.live) {
        const PoseContact& c = ws_.contacts[static_cast<size_t>(k)];
        acting = acting || c.lambda_n > 0.0 || c.lambda_r > 0.0 || c.lambda_t.squaredNorm() > 0.0;
      }
      converged_ = worst >= 0.0 && moved_since_build() <= slack_ && (!acting || sweep + 1 >= kMinPoseSweeps);
    }
  }

  /// One contact's normal, repulsion and friction corrections; returns its value less its
  /// acceptance before them (< 0: not yet accepted).
  double visit(PoseContact& c, const Eigen::Matrix3d& inv_inertia) {
    const Index v = b_.begin + c.i;
    const Vec3 arm = pose_.q * b_.rest[c.i];
    const Vec3 at = arm + pose_.c;
    const double value = c.h.value(anchor_[v], at);
    const double short_of = value - accept(c);
    // Normal: C = n·(p - a) + d >= aim, with λ_n >= 0 accumulated over the sweeps.
    const Vec3 rn = arm.cross(c.h.n);
    const double w = 1.0 / mass_ + rn.dot(inv_inertia * rn);
    const double next = std::max(0.0, c.lambda_n + (aim(c) - value) / w);
    const double dl = next - c.lambda_n;
    if (dl != 0.0) {
      c.lambda_n = next;
      apply((dl / mass_) * c.h.n, inv_inertia * rn * dl);
    }
    if (options_.repulsion_range > 0.0) {
      // XPBD repulsion of the pair's gap toward δ with compliance α̃, its multiplier kept >= 0.
      // A movable other side (cloth) answers the same λ_r in the per-vertex response and
      // so moves away by other_w λ_r: counted here, the sweeps converge to the pair's
      // impulse λ_r = -C / (w + other_w + α̃), not to the whole correction as if that side
      // were fixed.
      const double alpha = options_.repulsion_compliance;
      const double now_value = c.h.value(anchor_[v], pose_.q * b_.rest[c.i] + pose_.c) + c.pair.responds_w * c.lambda_r;
      const double rep =
          std::max(0.0, c.lambda_r + (c.pair.repel - now_value - alpha * c.lambda_r) / (w + c.pair.other_w + alpha));
      const double dr = rep - c.lambda_r;
      if (dr != 0.0) {
        c.lambda_r = rep;
        apply((dr / mass_) * c.h.n, inv_inertia * rn * dr);
      }
    }
    rub(c, inv_inertia);
    return short_of;
  }

  /// Friction on the contact point's tangential motion over the substep relative to the
  /// other side's closest point: static cancels it while |λ_t| <= μ_s λ_n, kinetic is
  /// bounded by μ_k λ_n (Müller et al. 2020, Sec. 3.5, with Coulomb's cone on the
  /// accumulated λ_t); the other side takes its share, Δλ = -C / (w_body + w_other).
  void rub(PoseContact& c, const Eigen::Matrix3d& inv_inertia) {
    const double pressed = c.lambda_n + c.lambda_r + c.pair.pressed;
    if (!options_.x_start || (b_.mu_s <= 0.0 && b_.mu_k <= 0.0)) return;
    if (pressed <= 0.0 && c.lambda_t.squaredNorm() == 0.0) return;
    const Index v = b_.begin + c.i;
    const Vec3 now = pose_.q * b_.rest[c.i] + pose_.c;
    const Vec3 moved = now - (*options_.x_start)[v] - c.pair.other_motion;
    const Vec3 slip = moved - c.h.n.dot(moved) * c.h.n;
    const double sl = slip.norm();
    Vec3 want = c.lambda_t;
    if (sl > 0.0) {
      const Vec3 t = slip / sl;
      const Vec3 rt = (now - pose_.c).cross(t);
      want -= (sl / (1.0 / mass_ + rt.dot(inv_inertia * rt) + c.pair.other_wt)) * t;
    }
    const double wl = want.norm();
    if (wl > b_.mu_s * pressed) want *= b_.mu_k * pressed / wl;
    const Vec3 dt = want - c.lambda_t;
    if (dt.squaredNorm() == 0.0) return;
    c.lambda_t = want;
    apply(dt / mass_, inv_inertia * (now - pose_.c).cross(dt));
  }

  /// Redundant contacts (a face resting on four corners) leave the sweeps converging
  /// slowly through the rotation's coupling: the last fraction of a violation is removed by
  /// translation alone (w = 1/M), a residual of a fraction of a percent of g dt² that
  /// would otherwise fail the exact check and halt the body. Over the live contacts,
  /// rebuilt when the centre has moved past the slack (the others cannot be reached before).
  void translation_sweeps() {
    const Eigen::Matrix3d turned = pose_.q.toRotationMatrix();
    for (int sweep = 0; sweep < kPoseSweeps && !converged_; ++sweep) {
      if (moved_since_build() > slack_) rebuild_live();
      double worst = 0.0;
      for (const Index k : ws_.live) {
        PoseContact& c = ws_.contacts[static_cast<size_t>(k)];
        const double value = c.h.value(anchor_[b_.begin + c.i], turned * b_.rest[c.i] + pose_.c);
        worst = std::min(worst, value - accept(c));
        if (value < aim(c)) {
          c.lambda_n += (aim(c) - value) * mass_;
          pose_.c += (aim(c) - value) * c.h.n;
        }
      }
      converged_ = worst >= 0.0 && moved_since_build() <= slack_;
    }
  }

  /// The largest α in [0, 1] for which the linear blend anchor + α (y - anchor) keeps every
  /// half-space and the step bound; `bound_limits`: the step bound set it.
  double blend_bound(const std::vector<Vec3>& y, bool& bound_limits) const {
    double alpha = 1.0;
    bound_limits = false;
    for (size_t i = 0; i < n_; ++i) {
      const Index v = b_.begin + static_cast<Index>(i);
      const Vec3 step = y[i] - anchor_[v];
      const double len = step.norm();
      if (len > step_bound_ && step_bound_ / len < alpha) {
        alpha = step_bound_ / len;
        bound_limits = true;
      }
      for (const HalfSpace& h : regions_.planes_of(v)) {
        const double along = h.n.dot(step);
        if (along < 0.0 && h.d >= 0.0 && h.d / -along < alpha) {
          alpha = h.d / -along;
          bound_limits = false;
        }
      }
    }
    return alpha;
  }

  /// The rigid path curves off the blend by O(α(1-α)θ²): a plane with d ~ 0 that the blend
  /// slides along is then crossed by that much at every α, and the body halted although
  /// both ends were admissible. Translation alone removes such a residual (as after the
  /// sweeps), over every plane of the body in order; the caller's exact check decides.
  void clear_by_translation(Pose& p) const {
    const Eigen::Matrix3d turned_p = p.q.toRotationMatrix();
    bool clear = false;
    for (int sweep = 0; sweep < kPoseSweeps && !clear; ++sweep) {
      clear = true;
      for (size_t i = 0; i < n_; ++i) {
        const Index v = b_.begin + static_cast<Index>(i);
        for (const HalfSpace& h : regions_.planes_of(v)) {
          const double value = h.value(anchor_[v], turned_p * b_.rest[i] + p.c);
          if (value < accept_of(h)) clear = false;
          if (value < aim_of(h)) p.c += (aim_of(h) - value) * h.n;
        }
      }
    }
  }

  /// Fallback (rare when the pose solve converged: the step bound, or a body the sweeps could
  /// not free). Line search along the rigid interpolation from the anchor pose (slerp, lerp)
  /// toward `target`. The bound of the linear blend is exact per half-space and per step-bound
  /// ball (both convex, both hold at α = 0); the rigid pose at that α is then verified and
  /// shrunk until admissible, since it deviates from the blend by O(α(1-α)θ²). No admissible α:
  /// the body halts at its anchor pose.
  void line_search(const Pose& target, bool regions_ok, double advance_tolerance, std::span<Vec3> xb,
                   RigidEnforceStats& st) {
    const std::span<const Vec3> ab(anchor_.data() + b_.begin, n_);
    const Pose from = fit(ab, std::span<const Vec3>(b_.rest), b_.weight);
    place(target, ws_.y);
    bool bound_limits = false;
    const double alpha = blend_bound(ws_.y, bound_limits);
    std::vector<Vec3>& z = ws_.z;
    bool found = false;
    // Small cuts first (the rigid pose leaves the blend by a second-order amount), then halvings.
    static constexpr double kShrink[] = {1.0, 1.0 - 1e-6, 1.0 - 1e-4, 0.99, 0.9};
    for (int k = 0; k < static_cast<int>(std::size(kShrink)) + kLineSearchHalvings && alpha > 0.0; ++k) {
      const double a = k < static_cast<int>(std::size(kShrink))
                           ? alpha * kShrink[k]
                           : alpha * 0.9 * std::ldexp(1.0, -(k - static_cast<int>(std::size(kShrink)) + 1));
      Pose p;
      p.q = from.q.slerp(a, target.q);
      p.c = from.c + a * (target.c - from.c);
      place(p, z);
      if (!admissible(z) && longest_step(z) <= step_bound_ * (1.0 - 1e-3)) {
        clear_by_translation(p);
        place(p, z);
      }
      if (admissible(z)) {
        found = true;
        if (bound_limits) bound_limits = a * (1.0 + advance_tolerance) < 1.0;
        break;
      }
    }
    if (found) {
      std::copy(z.begin(), z.end(), xb.begin());
      if (!regions_ok) ++st.bodies_shortened;
      if (bound_limits) ++st.bodies_bounded;
    } else {
      std::copy(ab.begin(), ab.end(), xb.begin());
      ++st.bodies_halted;
      st.vertices_halted += static_cast<Index>(n_);
    }
  }

  const Body& b_;
  Workspace& ws_;
  const Positions& anchor_;
  const RegionSet& regions_;
  const RigidContactOptions& options_;
  const double step_bound_;
  const double mass_;
  const size_t n_;
  const Index q_begin_, q_end_;  ///< the body's planes: one contiguous range of the RegionSet
  const double margin_;          ///< the pose solve aims this far inside every half-space
  const double slack_;           ///< how far beyond acting a plane joins the live contacts
  Pose pose_;                    ///< the pose the sweeps move
  Pose built_;                   ///< the pose the live contacts were listed at
  bool converged_ = false;
};

RigidEnforceStats RigidBodies::enforce(Positions& x, const Positions& anchor, const RegionSet& regions,
                                       double step_bound, double advance_tolerance, std::span<const Vec3> cores,
                                       const RigidContactOptions& options) const {
  std::vector<RigidEnforceStats> per(bodies_.size());
  work_.resize(bodies_.size());
  parallel_for(
      size(),
      [&](Index lo, Index hi) {
        for (Index bi = lo; bi < hi; ++bi) {
          const Body& b = bodies_[bi];
          const std::span<Vec3> xb(x.data() + b.begin, b.rest.size());
          const double core = cores.empty() ? 0.0 : b.core;
          const Pose target =
              fit(xb, std::span<const Vec3>(b.rest), b.weight, core, cores.empty() ? Vec3::Zero() : cores[bi]);
          const double bound =
              options.body_step_bound.empty() ? step_bound : std::min(step_bound, options.body_step_bound[bi]);
          PoseSolver solver(b, work_[static_cast<size_t>(bi)], anchor, regions, options, step_bound, bound,
                            b.mass + core);
          ++per[bi].bodies_refitted;
          if (b.pinned)
            solver.follow_pins(target, xb);
          else
            solver.solve(target, advance_tolerance, xb, per[bi]);
        }
      },
      1);
  RigidEnforceStats total;
  for (const auto& s : per) {
    total.bodies_refitted += s.bodies_refitted;
    total.bodies_shortened += s.bodies_shortened;
    total.bodies_halted += s.bodies_halted;
    total.vertices_halted += s.vertices_halted;
    total.bodies_bounded += s.bodies_bounded;
    total.vertices_violated += s.vertices_violated;
  }
  return total;
}

Index RigidBodies::body_of(Index v) const {
  const auto it = std::upper_bound(bodies_.begin(), bodies_.end(), v, [](Index u, const Body& b) { return u < b.end; });
  return it != bodies_.end() && v >= it->begin ? static_cast<Index>(it - bodies_.begin()) : -1;
}

std::vector<RigidFrame> RigidBodies::frames(const Positions& at) const {
  std::vector<RigidFrame> out(bodies_.size());
  for (size_t bi = 0; bi < bodies_.size(); ++bi) {
    const Body& b = bodies_[bi];
    if (b.pinned) continue;
    const Pose p = fit(std::span<const Vec3>(at.data() + b.begin, b.rest.size()), b.rest, b.weight);
    const Eigen::Matrix3d r = p.q.toRotationMatrix();
    out[bi].centre = p.c;
    out[bi].inv_inertia = r * b.inv_inertia * r.transpose();
    out[bi].inv_mass = 1.0 / (b.mass + b.core);
  }
  return out;
}

std::vector<RigidMotion> RigidBodies::motions(const Positions& from, const Positions& to) const {
  std::vector<RigidMotion> out(bodies_.size());
  for (size_t bi = 0; bi < bodies_.size(); ++bi) {
    const Body& b = bodies_[bi];
    if (b.pinned) continue;
    const Pose p0 = fit(std::span<const Vec3>(from.data() + b.begin, b.rest.size()), b.rest, b.weight);
    const Pose p1 = fit(std::span<const Vec3>(to.data() + b.begin, b.rest.size()), b.rest, b.weight);
    out[bi] = {p0.c, p1.c, (p1.q * p0.q.conjugate()).toRotationMatrix()};
  }
  return out;
}

void RigidBodies::displace(Positions& x, std::span<const Vec3> shift, std::span<const Vec3> turn) const {
  for (size_t bi = 0; bi < bodies_.size(); ++bi) {
    const Body& b = bodies_[bi];
    if (b.pinned || (shift[bi] == Vec3::Zero() && turn[bi] == Vec3::Zero())) continue;
    const std::span<Vec3> xb(x.data() + b.begin, b.rest.size());
    const Vec3 centre = fit(xb, b.rest, b.weight).c;
    const double angle = turn[bi].norm();
    const Eigen::Matrix3d r =
        angle > 0.0 ? Eigen::AngleAxisd(angle, turn[bi] / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
    for (Vec3& p : xb) p = centre + shift[bi] + r * (p - centre);
  }
}

Index RigidBodies::count_deformed(const Positions& x, double tolerance) const {
  std::atomic<Index> deformed{0};
  parallel_for(
      size(),
      [&](Index lo, Index hi) {
        for (Index bi = lo; bi < hi; ++bi) {
          const Body& b = bodies_[bi];
          const size_t n = b.rest.size();
          const std::span<const Vec3> xb(x.data() + b.begin, n);
          const Pose p = fit(xb, b.rest, b.weight);
          const Eigen::Matrix3d r = p.q.toRotationMatrix();
          Index local = 0;
          for (size_t i = 0; i < n; ++i)
            if (!((r * b.rest[i] + p.c - xb[i]).norm() <= tolerance * std::max(1.0, b.extent))) ++local;
          deformed += local;
        }
      },
      1);
  return deformed.load();
}

}  // namespace ccfr
