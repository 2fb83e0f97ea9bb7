#include "ccfr/feasibility/plesnik.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "ccfr/feasibility/exact_projector.hpp"
#include "small_buffer.hpp"

namespace ccfr {

void PlesnikRecursion::reset(const Vec3& start) {
  x0 = start;
  x = start;
  m = 0;
}

PlesnikRecursion::Step PlesnikRecursion::add(const Vec3& n, double beta, double tolerance) {
  if (m == 0) {
    // Lines 1-6: the first equation is a plain projection; v_0 = n spans its ERO line.
    const double beta0 = n.dot(n);
    if (!(beta0 > tolerance)) return Step::redundant;
    x += ((beta - n.dot(x)) / beta0) * n;
    v[0] = n;
    a[0] = n;
    b[0] = beta;
    m = 1;
    return Step::added;
  }
  // In R^3 a fourth equation is always dependent on three independent ones.
  if (m == 3) return Step::redundant;

  // Lines 8-15: the equiresidual point u on the current ERO line. Either orientation of the new
  // equation describes the same plane; take the one with the larger denominator (see header).
  const Vec3& vm = v[m - 1];
  const double c0 = a[0].dot(vm);
  const double nv = n.dot(vm);
  const double sign = std::abs(nv - c0) >= std::abs(-nv - c0) ? 1.0 : -1.0;
  const Vec3 am = sign * n;
  const double bm = sign * beta;
  const double beta_u = am.dot(vm) - c0;
  if (!(std::abs(beta_u) > tolerance)) return Step::redundant;
  const Vec3 u = x + ((bm - am.dot(x)) / beta_u) * vm;

  // Lines 16-25: w from w_0 = x^(0) + a_m through the stored ERO directions; the last step
  // (j = m) uses the new equation (clarification 1).
  Vec3 w = x0 + am;
  for (int j = 1; j <= m; ++j) {
    const Vec3& aj = j < m ? a[j] : am;
    const double bj = j < m ? b[j] : bm;
    const Vec3 dn = aj - a[0];
    const double beta_w = dn.dot(v[j - 1]);
    if (std::abs(beta_w) > tolerance) w += ((bj - b[0] - dn.dot(w)) / beta_w) * v[j - 1];
  }

  // Lines 26-35: the new ERO direction, and its intersection with P_0.
  const Vec3 v_new = w - u;
  const double scale = std::max({1.0, (u - x0).norm(), (w - x0).norm()});
  if (!(v_new.norm() > tolerance * scale)) return Step::redundant;
  const double beta_new = a[0].dot(v_new);
  if (std::abs(beta_new) < tolerance)
    x = u;
  else
    x = u + ((b[0] - a[0].dot(u)) / beta_new) * v_new;
  v[m] = v_new;
  a[m] = am;
  b[m] = bm;
  ++m;
  return Step::added;
}

Vec3 retract_toward_anchor(const Vec3& p, double epsilon) {
  const double len = p.norm();
  if (!(len > epsilon)) return Vec3::Zero();
  return p * ((len - epsilon) / len);
}

namespace {
/// A plane's value at the candidate and its index, ordered by value, ties by index: the order in
/// which Alg. ProjectOntoConvexRegion visits the planes. Trivial, so scratch arrays of it start
/// uninitialised (SmallBuffer).
struct PlaneKey {
  double rho;
  std::uint32_t index;
  friend bool operator<(const PlaneKey& a, const PlaneKey& b) {
    return a.rho < b.rho || (!(b.rho < a.rho) && a.index < b.index);
  }
};

/// What Lines 1-3 learn of the planes at the candidate.
struct CandidateValues {
  std::size_t near = 0;  ///< planes violated at the candidate (value < -tol): order[0, near)
  double d_min = 0.0;    ///< the smallest offset d (<= 0): the anchor's worst value
  double nn_max = 0.0;   ///< the largest |n|²
};

/// Lines 1-3: every plane's value at the candidate `q` (relative to the anchor) into `order`,
/// the violated ones (rho < -tol) from the front, the others from the back. False on a NaN value
/// (a non-finite plane: nothing can be certified). Fused with the sort keys instead of
/// screen_input(): this loop is Plesnik's hot path (the shared screen measured 20 % slower here
/// at 8-16 planes).
bool values_at_candidate(std::span<const HalfSpace> planes, const Vec3& q, double tol, SmallBuffer<PlaneKey>& order,
                         CandidateValues& out) {
  const auto count = planes.size();
  std::size_t far = count;
  for (std::size_t k = 0; k < count; ++k) {
    out.nn_max = std::max(out.nn_max, planes[k].n.squaredNorm());
    const double rho = planes[k].n.dot(q) + planes[k].d;
    if (std::isnan(rho)) return false;
    out.d_min = std::min(out.d_min, planes[k].d);
    order[rho < -tol ? out.near++ : --far] = {rho, static_cast<std::uint32_t>(k)};
  }
  return true;
}

/// The passes of Alg. ProjectOntoConvexRegion (Lines 9-19) over planes whose values at the
/// candidate are in `order`, and the re-check after each pass (clarification 2). Points are
/// relative to the anchor.
///
/// Lines 9-19 visit the planes in ascending violation depth at the candidate, ties by index, so
/// the result does not depend on a sort. Nothing is sorted up front (sorting was 16 % of a
/// card-stack frame, and then 4 % of a twisting-rope frame for the planes not violated at the
/// candidate): a pass acts only on the planes violated at its current point, and that point moves
/// only when a plane is added. So each step collects the violated planes after the last added
/// key and takes the smallest, which is usually added; the others wait for the next collection,
/// since the move may satisfy them. This visits the planes exactly as the full sort does.
class PlesnikPasses {
 public:
  PlesnikPasses(std::span<const HalfSpace> planes, const SmallBuffer<PlaneKey>& order, const CandidateValues& values,
                const Vec3& q, const ProjectorParams& params)
      : planes_(planes),
        order_(order),
        near_(values.near),
        params_(params),
        tol_(params.feasibility_tolerance),
        pending_(planes.size()),
        shortlist_(planes.size()),
        q_(q),
        n_max_(std::sqrt(values.nn_max)),
        q_norm_(q.norm()) {}

  /// One pass from `x_check` (Lines 9-19): adds the violated planes to `rec` in key order until
  /// three independent equations fix the point or none is violated; `x_check` ends at the
  /// retracted point. `at_candidate`: the pass starts at the candidate, where the violated
  /// planes are order[0, near).
  void visit(Vec3& x_check, PlesnikRecursion& rec, bool at_candidate) {
    PlaneKey after{-std::numeric_limits<double>::infinity(), 0};
    // Three independent equations fix the point: every later plane is dependent (add() says so).
    while (rec.m < 3) {
      std::size_t np = 0;
      if (at_candidate) {
        np = near_;
        std::copy(order_.begin(), order_.begin() + near_, pending_.begin());
        at_candidate = false;
      } else {
        const double limit = bound_limit(x_check);
        for (const PlaneKey& key : planes_to_scan(limit)) {
          if (holds_by_bound(key.rho, limit) || !(after < key)) continue;
          const HalfSpace& h = planes_[key.index];
          if (!(h.n.dot(x_check) + h.d >= -tol_)) pending_[np++] = key;  // line 10
        }
      }
      if (np == 0) return;
      std::swap(pending_[0], *std::min_element(pending_.begin(), pending_.begin() + np));
      std::size_t j = 0;
      auto add = [&](std::size_t at) {
        // Line 11: n_k . (x - x_anchor) = -d_k is the plane in anchor-relative coordinates.
        const HalfSpace& h = planes_[pending_[at].index];
        return rec.add(h.n, -h.d, params_.redundancy_tolerance) == PlesnikRecursion::Step::added;
      };
      if (!add(0)) {  // dependent on the stored equations (rare): the next ones in key order
        std::sort(pending_.begin() + 1, pending_.begin() + np);
        for (j = 1; j < np && !add(j);) ++j;
        if (j == np) return;  // every one dependent: the point did not move
      }
      x_check = retract_toward_anchor(rec.x, params_.epsilon);  // lines 15-19
      after = pending_[j];
    }
  }

  /// Clarification 2: whether every constraint holds at `x` after the pass.
  bool all_hold(const Vec3& x) {
    const double limit = bound_limit(x);
    for (const PlaneKey& key : planes_to_scan(limit)) {
      if (holds_by_bound(key.rho, limit)) continue;
      const HalfSpace& h = planes_[key.index];
      if (!(h.n.dot(x) + h.d >= -tol_)) return false;
    }
    return true;
  }

 private:
  // A plane's value moves by at most |n| |x - q| from its value rho at the candidate, so planes
  // with rho well above that hold at x without evaluating them: a dense vertex has ~150 planes,
  // 3-4 violated (soft-wire pile), and the scans then read only its rho. The margin covers
  // the rounding of |n|, |x - q| and both values (a few ulps of |n| (|x| + |q|) and |rho|), so
  // exactly the planes an evaluation would find violated are evaluated.
  static bool holds_by_bound(double rho, double limit) { return rho - 1e-14 * std::abs(rho) > limit; }
  double bound_limit(const Vec3& x) const {
    return n_max_ * ((x - q_).norm() * (1.0 + 1e-12) + 1e-14 * (x.norm() + q_norm_)) - tol_;
  }
  // The scans read a shortlist: the entries of `order`, in their order, that do not hold by bound
  // at `short_limit`. A plane that holds by bound there holds by bound at every smaller limit, so a
  // scan with limit <= short_limit skips exactly the planes a scan of all of `order` would. The
  // limit grows as the point leaves the candidate; a scan beyond the shortlist's limit rebuilds it
  // at twice its own. A vertex of the soft-wire pile then scans about 16 of its ~150 planes.
  std::span<const PlaneKey> planes_to_scan(double limit) {
    if (!(limit <= short_limit_)) {
      short_limit_ = limit + std::max(limit, 0.0) + tol_;
      n_short_ = 0;
      for (std::size_t i = 0; i < planes_.size(); ++i)
        if (!holds_by_bound(order_[i].rho, short_limit_)) shortlist_[n_short_++] = order_[i];
    }
    return std::span<const PlaneKey>(shortlist_.begin(), n_short_);
  }

  std::span<const HalfSpace> planes_;
  const SmallBuffer<PlaneKey>& order_;
  const std::size_t near_;
  const ProjectorParams& params_;
  const double tol_;
  SmallBuffer<PlaneKey> pending_;
  SmallBuffer<PlaneKey> shortlist_;
  std::size_t n_short_ = 0;
  double short_limit_ = -std::numeric_limits<double>::infinity();
  const Vec3 q_;         ///< the candidate
  const double n_max_;   ///< the largest |n|
  const double q_norm_;  ///< |q|
};

/// A pass whose point `x_pass` (relative to the anchor) satisfies every plane. The anchor is
/// feasible and |0 - q| from the candidate, so the projection is never farther. Plesník's point
/// can be (it never drops an equality): it is then replaced by the exact projection.
ProjectResult converged(ProjectResult res, const Vec3& x_anchor, const Vec3& x_candidate, const Vec3& x_pass,
                        const Vec3& q, std::span<const HalfSpace> planes, const ProjectorParams& params) {
  if ((x_pass - q).squaredNorm() > q.squaredNorm()) {
    const ProjectResult e = ExactProjector(params).project(x_anchor, x_candidate, planes);
    res.fell_back = true;
    res.x = e.status == ProjectStatus::projected ? e.x : x_anchor;
    res.status = e.status == ProjectStatus::projected ? ProjectStatus::projected : ProjectStatus::halted;
    return res;
  }
  res.x = x_anchor + x_pass;
  res.status = ProjectStatus::projected;
  return res;
}

/// Line 24: no convergence within the budget; the anchor is feasible here (all d_k >= -tol), so
/// the region is not empty and its exact projection exists. The passes mostly fail by cycling:
/// each keeps only the planes violated at its start as equalities, and two opposing or nearly
/// parallel planes then push the point back and forth (measured on the paper's scenes,
/// docs/results.md "Halting"). The exact projection ends the cycle; halt only if it fails too.
ProjectResult out_of_iterations(ProjectResult res, const Vec3& x_anchor, const Vec3& x_candidate,
                                std::span<const HalfSpace> planes, const ProjectorParams& params) {
  if (params.exact_fallback) {
    const ProjectResult e = ExactProjector(params).project(x_anchor, x_candidate, planes);
    if (e.status == ProjectStatus::projected) {
      res.x = e.x;
      res.status = ProjectStatus::projected;
      res.rescued = true;
      return res;
    }
  }
  res.x = x_anchor;
  res.status = ProjectStatus::halted;
  return res;
}
}  // namespace

PlesnikProjector::PlesnikProjector(const ProjectorParams& params) : params_(params) { validate(params_); }

ProjectResult PlesnikProjector::project(const Vec3& x_anchor, const Vec3& x_candidate,
                                        std::span<const HalfSpace> planes) const {
  const double tol = params_.feasibility_tolerance;
  if (!x_candidate.allFinite() || !x_anchor.allFinite()) return unusable_input(x_anchor);
  // Lines 1-3: values at the candidate, relative to the anchor.
  const Vec3 q = x_candidate - x_anchor;
  ProjectResult res;
  res.x = x_candidate;
  SmallBuffer<PlaneKey> order(planes.size());
  CandidateValues values;
  if (!values_at_candidate(planes, q, tol, order, values)) return unusable_input(x_anchor);
  res.active = static_cast<int>(values.near);
  if (res.active == 0) return res;

  // Clarification 7: the anchor violates a plane, so neither the retraction toward it nor the
  // fallback to it keeps the vertex feasible. The exact projection is the defined answer.
  if (values.d_min < -tol) {
    const ExactProjector exact(params_);
    ProjectResult r = exact.project(x_anchor, x_candidate, planes);
    r.active = res.active;
    return r;
  }

  PlesnikPasses passes(planes, order, values, q, params_);
  PlesnikRecursion rec;
  Vec3 x_pass = q;  // x' of the paper, relative to the anchor
  for (int it = 1; it <= params_.max_iterations; ++it) {
    rec.reset(x_pass);
    Vec3 x_check = x_pass;  // the retracted point, where constraints are evaluated
    passes.visit(x_check, rec, it == 1);
    x_pass = x_check;
    res.iterations = it;
    if (passes.all_hold(x_pass)) return converged(res, x_anchor, x_candidate, x_pass, q, planes, params_);
  }
  return out_of_iterations(res, x_anchor, x_candidate, planes, params_);
}

}  // namespace ccfr
