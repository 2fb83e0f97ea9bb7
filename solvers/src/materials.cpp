#include "ccfr/solvers/materials.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include <Eigen/LU>
#include <Eigen/SVD>

#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"

namespace ccfr {

namespace xpbd {

namespace {
/// Wraps an angle difference into (-π, π], so a dihedral angle crossing ±π does not jump by 2π.
double wrap_angle(double a) {
  constexpr double pi = std::numbers::pi;
  while (a > pi) a -= 2.0 * pi;
  while (a <= -pi) a += 2.0 * pi;
  return a;
}

/// A triangle whose doubled area |n| is below this fraction of |e|² has a numerically meaningless
/// normal; its dihedral gradient (∝ 1/height) is then skipped rather than amplified.
constexpr double kRelativeArea = 1e-12;
}  // namespace

double dihedral_angle(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3) {
  const Vec3 e = x1 - x0;
  const Vec3 n1 = e.cross(x2 - x0), n2 = (x3 - x0).cross(e);
  const double l = e.norm(), a1 = n1.norm(), a2 = n2.norm();
  if (!(l > 0.0) || !(a1 > kRelativeArea * l * l) || !(a2 > kRelativeArea * l * l)) return 0.0;
  // atan2 of unnormalised sine and cosine: both carry the same factor |n1||n2|.
  return std::atan2(n1.cross(n2).dot(e) / l, n1.dot(n2));
}

bool dihedral_angle_gradient(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3, double& theta,
                             std::array<Vec3, 4>& grad) {
  const Vec3 e = x1 - x0;
  const Vec3 n1 = e.cross(x2 - x0), n2 = (x3 - x0).cross(e);
  const double l2 = e.squaredNorm(), a1 = n1.squaredNorm(), a2 = n2.squaredNorm();
  const double l = std::sqrt(l2);
  const double min_area2 = kRelativeArea * kRelativeArea * l2 * l2;
  if (!(l > 0.0) || !(a1 > min_area2) || !(a2 > min_area2) || !std::isfinite(a1 + a2)) return false;
  const double inv_l = 1.0 / l;  // one division each instead of nine: the sweep is latency-bound
  theta = std::atan2(n1.cross(n2).dot(e) * inv_l, n1.dot(n2));
  const Vec3 m1 = n1 * (1.0 / a1), m2 = n2 * (1.0 / a2);  // n / |n|²
  grad[2] = -l * m1;
  grad[3] = -l * m2;
  grad[0] = -((x2 - x1).dot(e) * inv_l) * m1 - ((x3 - x1).dot(e) * inv_l) * m2;
  grad[1] = -grad[0] - grad[2] - grad[3];
  return true;
}

void solve_dihedral_bending(const std::array<Vec3*, 4>& x, const std::array<double, 4>& w, double rest_angle,
                            double alpha_tilde, double& lambda) {
  double theta = 0.0;
  std::array<Vec3, 4> g;
  if (!dihedral_angle_gradient(*x[0], *x[1], *x[2], *x[3], theta, g)) return;
  apply_update<4>(x, w, g, wrap_angle(theta - rest_angle), alpha_tilde, lambda);
}

double turning_angle(const Vec3& x0, const Vec3& x1, const Vec3& x2) {
  const Vec3 e1 = x1 - x0, e2 = x2 - x1;
  if (!(e1.squaredNorm() > 0.0) || !(e2.squaredNorm() > 0.0)) return 0.0;
  return std::atan2(e1.cross(e2).norm(), e1.dot(e2));
}

bool turning_angle_gradient(const Vec3& x0, const Vec3& x1, const Vec3& x2, double& phi, std::array<Vec3, 3>& grad) {
  const Vec3 e1 = x1 - x0, e2 = x2 - x1;
  const double l1 = e1.norm(), l2 = e2.norm();
  if (!(l1 > 0.0) || !(l2 > 0.0) || !std::isfinite(l1 + l2)) return false;
  const Vec3 u = e1 / l1, v = e2 / l2;
  const double s = u.cross(v).norm(), c = u.dot(v);
  // Below this sine the direction of the in-plane normal is round-off; the angle is a cone point.
  if (!(s > 1e-12)) return false;
  phi = std::atan2(s, c);
  const Vec3 p1 = (v - c * u) / s, p2 = (u - c * v) / s;
  grad[0] = p1 / l1;
  grad[2] = -p2 / l2;
  grad[1] = -grad[0] - grad[2];
  return true;
}

void solve_strand_bending(const std::array<Vec3*, 3>& x, const std::array<double, 3>& w, double rest_angle,
                          double alpha_tilde, double& lambda) {
  double phi = 0.0;
  std::array<Vec3, 3> g;
  if (!turning_angle_gradient(*x[0], *x[1], *x[2], phi, g)) return;
  apply_update<3>(x, w, g, phi - rest_angle, alpha_tilde, lambda);
}

double tet_six_volume(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3) {
  return (x1 - x0).dot((x2 - x0).cross(x3 - x0));
}

double tet_volume_constraint(const std::array<Vec3, 4>& x, double rest_volume, std::array<Vec3, 4>& grad) {
  const Vec3 d1 = x[1] - x[0], d2 = x[2] - x[0], d3 = x[3] - x[0];
  grad[1] = d2.cross(d3);
  grad[2] = d3.cross(d1);
  grad[3] = d1.cross(d2);
  grad[0] = -grad[1] - grad[2] - grad[3];
  return d1.dot(grad[1]) - 6.0 * rest_volume;
}

void solve_tet_volume(const std::array<Vec3*, 4>& x, const std::array<double, 4>& w, double rest_volume,
                      double alpha_tilde, double& lambda) {
  std::array<Vec3, 4> g;
  const double c = tet_volume_constraint({*x[0], *x[1], *x[2], *x[3]}, rest_volume, g);
  apply_update<4>(x, w, g, c, alpha_tilde, lambda);
}

bool tet_deviatoric_constraint(const std::array<Vec3, 4>& x, const Eigen::Matrix3d& rest_inverse, double& c,
                               std::array<Vec3, 4>& grad) {
  Eigen::Matrix3d ds;
  ds.col(0) = x[1] - x[0];
  ds.col(1) = x[2] - x[0];
  ds.col(2) = x[3] - x[0];
  const Eigen::Matrix3d f = ds * rest_inverse;
  if (!f.allFinite()) return false;
  // Newton instead of the SVD: the material stage of tet scenes is dominated by this (issue 13).
  const Eigen::Matrix3d diff = f - polar_rotation_newton(f);
  const double norm = diff.norm();
  // At (or within round-off of) a rotation the constraint holds and its direction is undefined.
  if (!(norm > 1e-14)) return false;
  c = norm;
  const Eigen::Matrix3d h = (diff / norm) * rest_inverse.transpose();
  grad[1] = h.col(0);
  grad[2] = h.col(1);
  grad[3] = h.col(2);
  grad[0] = -grad[1] - grad[2] - grad[3];
  return true;
}

void solve_tet_deviatoric(const std::array<Vec3*, 4>& x, const std::array<double, 4>& w,
                          const Eigen::Matrix3d& rest_inverse, double alpha_tilde, double& lambda) {
  double c = 0.0;
  std::array<Vec3, 4> g;
  if (!tet_deviatoric_constraint({*x[0], *x[1], *x[2], *x[3]}, rest_inverse, c, g)) return;
  apply_update<4>(x, w, g, c, alpha_tilde, lambda);
}

Eigen::Matrix3d polar_rotation(const Eigen::Matrix3d& a) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(a, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d& u = svd.matrixU();
  const Eigen::Matrix3d& v = svd.matrixV();
  // Flip the axis of the smallest singular value (last in Eigen's order) when U Vᵀ is a
  // reflection: the closest rotation, and the right answer for flat bodies (rank 2).
  Eigen::Vector3d d(1.0, 1.0, (u * v.transpose()).determinant() < 0.0 ? -1.0 : 1.0);
  return u * d.asDiagonal() * v.transpose();
}

Eigen::Matrix3d polar_rotation_newton(const Eigen::Matrix3d& a) {
  constexpr int kMaxIterations = 16;  // never reached for det A > 1e-6 ‖A‖³ (σ_min/σ_max ≥ 1e-6 roughly)
  // Quadratic convergence: the iterate after a step of size s is off by about s²/2, so a step below
  // 1e-7 leaves it within 5e-15 of the limit and no confirming step is needed.
  constexpr double kLastStepSq = 1e-14;
  Eigen::Matrix3d x = a;
  for (int it = 0; it < kMaxIterations; ++it) {
    // X^{-T} = cof(X) / det X, the cofactor columns being cross products of X's columns.
    Eigen::Matrix3d cof;
    cof.col(0) = x.col(1).cross(x.col(2));
    cof.col(1) = x.col(2).cross(x.col(0));
    cof.col(2) = x.col(0).cross(x.col(1));
    const double det = x.col(0).dot(cof.col(0));
    const double norm_sq = x.squaredNorm();
    if (!(det > 1e-6 * norm_sq * std::sqrt(norm_sq))) break;  // inverted, flat or NaN: SVD
    // ζ = (‖X^{-T}‖ / ‖X‖)^{1/2} = (‖cof X‖² / (det² ‖X‖²))^{1/4}.
    const double zeta = std::sqrt(std::sqrt(cof.squaredNorm() / (det * det * norm_sq)));
    const Eigen::Matrix3d next = (0.5 * zeta) * x + (0.5 / (zeta * det)) * cof;
    const double step_sq = (next - x).squaredNorm();
    x = next;
    if (step_sq < kLastStepSq) return x;
  }
  return polar_rotation(a);
}

void solve_shape_matching(std::span<Vec3> x, std::span<const double> w, std::span<const Vec3> q,
                          std::span<const double> m) {
  const size_t n = x.size();
  double total = 0.0;
  Vec3 c = Vec3::Zero();
  for (size_t i = 0; i < n; ++i) {
    total += m[i];
    c += m[i] * x[i];
  }
  if (!(total > 0.0)) return;
  c /= total;
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < n; ++i) a.noalias() += m[i] * (x[i] - c) * q[i].transpose();
  if (!a.allFinite()) return;
  const Eigen::Matrix3d r = polar_rotation(a);
  for (size_t i = 0; i < n; ++i)
    if (w[i] > 0.0) x[i] = r * q[i] + c;
}

}  // namespace xpbd

// ---- BendingBatch -------------------------------------------------------------------------------

void BendingBatch::add(const Vec4i& v, double theta0, double alpha) {
  ids.push_back(v);
  rest_angle.push_back(theta0);
  compliance.push_back(alpha);
  lambda.push_back(0.0);
}

void BendingBatch::reset_multipliers() { std::fill(lambda.begin(), lambda.end(), 0.0); }

void BendingBatch::solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> w, double dt) {
  const double inv_dt2 = 1.0 / (dt * dt);
  for (const Index c : order) {
    const Vec4i& v = ids[c];
    xpbd::solve_dihedral_bending({&x[v[0]], &x[v[1]], &x[v[2]], &x[v[3]]}, {w[v[0]], w[v[1]], w[v[2]], w[v[3]]},
                                 rest_angle[c], compliance[c] * inv_dt2, lambda[c]);
  }
}

// ---- StrandBendingBatch -------------------------------------------------------------------------

void StrandBendingBatch::add(const Vec3i& v, double phi0, double alpha) {
  ids.push_back(v);
  rest_angle.push_back(phi0);
  compliance.push_back(alpha);
  lambda.push_back(0.0);
}

void StrandBendingBatch::reset_multipliers() { std::fill(lambda.begin(), lambda.end(), 0.0); }

void StrandBendingBatch::solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> w,
                                        double dt) {
  const double inv_dt2 = 1.0 / (dt * dt);
  for (const Index c : order) {
    const Vec3i& v = ids[c];
    xpbd::solve_strand_bending({&x[v[0]], &x[v[1]], &x[v[2]]}, {w[v[0]], w[v[1]], w[v[2]]}, rest_angle[c],
                               compliance[c] * inv_dt2, lambda[c]);
  }
}

// ---- TetBatch -----------------------------------------------------------------------------------

bool TetBatch::add(const Vec4i& v, const Positions& rest, double volume_compliance_per_volume,
                   double shear_compliance_per_volume) {
  Eigen::Matrix3d dm;
  dm.col(0) = rest[v[1]] - rest[v[0]];
  dm.col(1) = rest[v[2]] - rest[v[0]];
  dm.col(2) = rest[v[3]] - rest[v[0]];
  const double six_v = dm.determinant();
  // Scale-free degeneracy test: 6V against the cube of the longest edge of the rest tet.
  double lmax = std::max({dm.col(0).norm(), dm.col(1).norm(), dm.col(2).norm(), (dm.col(1) - dm.col(0)).norm(),
                          (dm.col(2) - dm.col(0)).norm(), (dm.col(2) - dm.col(1)).norm()});
  if (!(std::abs(six_v) > 1e-12 * lmax * lmax * lmax)) return false;
  const double v0 = six_v / 6.0;
  ids.push_back(v);
  rest_volume.push_back(v0);
  rest_inverse.push_back(dm.inverse());
  // Energy densities λ/2 (J-1)² and μ/2 ‖F-R‖² integrated over V_0 give these per-tet compliances,
  // so the stiffness does not depend on the mesh resolution.
  volume_compliance.push_back(36.0 * std::abs(v0) * volume_compliance_per_volume);
  deviatoric_compliance.push_back(shear_compliance_per_volume / std::abs(v0));
  lambda_volume.push_back(0.0);
  lambda_deviatoric.push_back(0.0);
  return true;
}

void TetBatch::reset_multipliers() {
  std::fill(lambda_volume.begin(), lambda_volume.end(), 0.0);
  std::fill(lambda_deviatoric.begin(), lambda_deviatoric.end(), 0.0);
}

void TetBatch::solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> w, double dt) {
  const double inv_dt2 = 1.0 / (dt * dt);
  for (const Index c : order) {
    const Vec4i& v = ids[c];
    const std::array<Vec3*, 4> p{&x[v[0]], &x[v[1]], &x[v[2]], &x[v[3]]};
    const std::array<double, 4> wv{w[v[0]], w[v[1]], w[v[2]], w[v[3]]};
    xpbd::solve_tet_deviatoric(p, wv, rest_inverse[c], deviatoric_compliance[c] * inv_dt2, lambda_deviatoric[c]);
    xpbd::solve_tet_volume(p, wv, rest_volume[c], volume_compliance[c] * inv_dt2, lambda_volume[c]);
  }
}

// ---- ShapeMatchingBatch -------------------------------------------------------------------------

void ShapeMatchingBatch::add(Index first, Index last, const Positions& rest, std::span<const double> inv_mass) {
  if (row_start.empty()) row_start.push_back(0);
  begin.push_back(first);
  end.push_back(last);
  double max_mass = 0.0;
  for (Index i = first; i < last; ++i) {
    if (inv_mass[i] > 0.0) max_mass = std::max(max_mass, 1.0 / inv_mass[i]);
  }
  // A kinematic vertex has infinite mass: the body must follow it. A weight 1e9 times the heaviest
  // dynamic vertex reproduces that limit to round-off while the dynamic vertices still fix the
  // rotation about axes the kinematic ones leave free (one or two pins, or collinear pins).
  const double kinematic_weight = max_mass > 0.0 ? 1e9 * max_mass : 1.0;
  const size_t base = weight.size();
  double total = 0.0;
  Vec3 centre = Vec3::Zero();
  for (Index i = first; i < last; ++i) {
    const double m = inv_mass[i] > 0.0 ? 1.0 / inv_mass[i] : kinematic_weight;
    weight.push_back(m);
    total += m;
    centre += m * rest[i];
  }
  centre /= total > 0.0 ? total : 1.0;
  for (Index i = first; i < last; ++i) rest_offset.push_back(rest[i] - centre);
  row_start.push_back(static_cast<Index>(base) + (last - first));
}

void ShapeMatchingBatch::solve(Positions& x, std::span<const double> w) const {
  parallel_for(
      size(),
      [&](Index lo, Index hi) {
        for (Index b = lo; b < hi; ++b) {
          const size_t n = static_cast<size_t>(end[b] - begin[b]);
          const size_t o = static_cast<size_t>(row_start[b]);
          xpbd::solve_shape_matching(
              std::span<Vec3>(x.data() + begin[b], n), w.subspan(static_cast<size_t>(begin[b]), n),
              std::span<const Vec3>(rest_offset.data() + o, n), std::span<const double>(weight.data() + o, n));
        }
      },
      1);
}

void ShapeMatchingBatch::predict(const Positions& x, const Positions& v, std::span<const double> inv_mass, double dt,
                                 const Vec3& g_dt2, Positions& predicted) const {
  parallel_for(
      size(),
      [&](Index lo, Index hi) {
        for (Index b = lo; b < hi; ++b) {
          const size_t n = static_cast<size_t>(end[b] - begin[b]);
          const size_t o = static_cast<size_t>(row_start[b]);
          bool dynamic = true;
          for (Index i = begin[b]; i < end[b] && dynamic; ++i) dynamic = inv_mass[i] > 0.0;
          if (!dynamic) continue;  // pinned bodies follow their pins through shape matching
          double total = 0.0;
          Vec3 c = Vec3::Zero(), c_prev = Vec3::Zero();
          for (size_t k = 0; k < n; ++k) {
            const Index i = begin[b] + static_cast<Index>(k);
            total += weight[o + k];
            c += weight[o + k] * x[i];
            c_prev += weight[o + k] * (x[i] - dt * v[i]);
          }
          c /= total;
          c_prev /= total;
          Eigen::Matrix3d a = Eigen::Matrix3d::Zero(), a_prev = Eigen::Matrix3d::Zero();
          for (size_t k = 0; k < n; ++k) {
            const Index i = begin[b] + static_cast<Index>(k);
            a.noalias() += weight[o + k] * (x[i] - c) * rest_offset[o + k].transpose();
            a_prev.noalias() += weight[o + k] * (x[i] - dt * v[i] - c_prev) * rest_offset[o + k].transpose();
          }
          const Eigen::Matrix3d r = xpbd::polar_rotation(a);
          const Eigen::Matrix3d next = r * xpbd::polar_rotation(a_prev).transpose() * r;  // ΔR R
          const Vec3 centre = 2.0 * c - c_prev + g_dt2;
          for (size_t k = 0; k < n; ++k)
            predicted[begin[b] + static_cast<Index>(k)] = next * rest_offset[o + k] + centre;
        }
      },
      1);
}

// ---- MaterialSystem -----------------------------------------------------------------------------

MaterialSystem::MaterialSystem(MaterialSystem&&) noexcept = default;
MaterialSystem& MaterialSystem::operator=(MaterialSystem&&) noexcept = default;
MaterialSystem::~MaterialSystem() = default;

MaterialSystem::MaterialSystem(const Topology& topo, const SimState& state, const SimulationParams& params) {
  if (params.objects.size() != topo.objects.size())
    throw std::logic_error("MaterialSystem: params.objects has " + std::to_string(params.objects.size()) +
                           " entries for " + std::to_string(topo.objects.size()) + " objects");
  const MaterialConstraintRegistry& registry = material_constraints();
  // A material may only enable registered constraints that take parameters (the scene loader's
  // schema checks the same; scenes built in code come here directly).
  for (size_t oi = 0; oi < topo.objects.size(); ++oi)
    for (const auto& [name, values] : params.objects[oi].material.constraints) {
      const auto* e = registry.find(name);
      if (!e || e->params.empty()) {
        std::string known;
        for (const auto& k : registry.entries())
          if (!k.params.empty()) known += (known.empty() ? "" : ", ") + k.name;
        throw Error("object '" + topo.objects[oi].name + "': its material enables " +
                    (e ? "material constraint '" + name + "', which takes no parameters and is always on"
                       : "unknown material constraint '" + name + "'") +
                    " (constraints set per material: " + (known.empty() ? std::string("none") : known) + ")");
      }
    }

  const Index nv = topo.num_vertices();
  for (const auto& e : registry.entries()) {
    std::vector<ParamValues> complete(topo.objects.size());
    MaterialContext ctx{topo, state, params, std::vector<const ParamValues*>(topo.objects.size(), nullptr)};
    for (size_t oi = 0; oi < topo.objects.size(); ++oi) {
      const auto& given = params.objects[oi].material.constraints;
      const auto it = given.find(e.name);
      if (it == given.end()) continue;
      complete[oi] = complete_params(e.params, it->second,
                                     "material constraint '" + e.name + "' of object '" + topo.objects[oi].name + "'");
      ctx.object_params[oi] = &complete[oi];
    }
    auto batch = e.make(complete_params(e.params, {}, "material constraint '" + e.name + "'"), ctx);
    if (!batch) continue;
    batch->finalize(nv, state.inv_mass);
    stages_.push_back({e.name, std::move(batch), {}, {}});
  }
  std::stable_sort(stages_.begin(), stages_.end(),
                   [](const Stage& a, const Stage& b) { return a.batch->sweep_rank() < b.batch->sweep_rank(); });

  for (const auto& o : topo.objects)
    if (o.kind == ObjectKind::rigid && o.num_vertices() > 0)
      rigid_.add(o.vertex_begin, o.vertex_end, state.rest, state.inv_mass);
  build_schedule(nv, state.inv_mass);
}

namespace {

/// Union-find over vertices with path halving.
struct Islands {
  std::vector<Index> parent;
  explicit Islands(Index n) : parent(static_cast<size_t>(n)) {
    for (Index i = 0; i < n; ++i) parent[i] = i;
  }
  Index find(Index i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  }
  void unite(Index a, Index b) {
    a = find(a), b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

}  // namespace

void MaterialSystem::build_schedule(Index nv, std::span<const double> inv_mass) {
  // Islands: dynamic vertices joined by constraints. Kinematic vertices are never written, so they
  // join nothing; a constraint with only kinematic vertices belongs to the key of its first vertex.
  Islands uf(nv);
  for (const Stage& s : stages_) {
    const std::span<const Index> ids = s.batch->vertex_ids();
    const int arity = s.batch->arity();
    for (Index c = 0; c < s.batch->size(); ++c) {
      Index first = -1;
      for (int a = 0; a < arity; ++a) {
        const Index v = ids[c * arity + a];
        if (inv_mass[v] == 0.0) continue;
        if (first < 0)
          first = v;
        else
          uf.unite(first, v);
      }
    }
  }
  auto key = [&](const ConstraintBatch& batch, Index c) {
    const std::span<const Index> ids = batch.vertex_ids();
    const int arity = batch.arity();
    for (int a = 0; a < arity; ++a)
      if (inv_mass[ids[c * arity + a]] != 0.0) return uf.find(ids[c * arity + a]);
    return ids[c * arity];
  };

  // Island ids in order of first appearance (batches in sweep order, constraints in colour order).
  std::vector<Index> island_of_key(static_cast<size_t>(nv), -1);
  Index num_islands = 0;
  std::vector<char> large;
  std::vector<double> cost;
  std::vector<Index> colour_count;  // per island, constraints in the current colour
  for (const Stage& s : stages_) {
    const ConstraintBatch& batch = *s.batch;
    const Colouring& col = batch.colouring;
    const Index grain = batch.grain();
    const double unit_cost = batch.unit_cost();
    for (Index k = 0; k < col.colours(); ++k) {
      std::vector<Index> touched;
      for (Index t = col.row_start[k]; t < col.row_start[k + 1]; ++t) {
        Index& id = island_of_key[key(batch, col.order[t])];
        if (id < 0) {
          id = num_islands++;
          large.push_back(0);
          cost.push_back(0.0);
          colour_count.push_back(0);
        }
        if (colour_count[id]++ == 0) touched.push_back(id);
        cost[id] += unit_cost;
      }
      for (const Index id : touched) {
        // Beyond the grain the colour-by-colour loop would split this island's colour into tasks.
        if (colour_count[id] > grain) large[id] = 1;
        colour_count[id] = 0;
      }
    }
  }

  // Small islands numbered by decreasing cost (ties by first appearance): the order does not change
  // the result, only the load balance.
  std::vector<Index> small;
  for (Index i = 0; i < num_islands; ++i)
    if (!large[i]) small.push_back(i);
  std::stable_sort(small.begin(), small.end(), [&](Index a, Index b) { return cost[a] > cost[b]; });
  std::vector<Index> small_index(static_cast<size_t>(num_islands), -1);
  for (size_t s = 0; s < small.size(); ++s) small_index[small[s]] = static_cast<Index>(s);
  small_islands_ = static_cast<Index>(small.size());
  large_islands_ = num_islands - small_islands_;

  for (Stage& s : stages_) {
    const ConstraintBatch& batch = *s.batch;
    const Colouring& col = batch.colouring;
    IslandOrder& by_island = s.small;
    Colouring& large_col = s.large;
    by_island.row_start.assign(static_cast<size_t>(small_islands_) + 1, 0);
    by_island.order.clear();
    large_col = Colouring{};
    large_col.row_start.push_back(0);
    for (Index t = 0; t < static_cast<Index>(col.order.size()); ++t) {
      const Index si = small_index[island_of_key[key(batch, col.order[t])]];
      if (si >= 0) ++by_island.row_start[si + 1];
    }
    for (Index si = 0; si < small_islands_; ++si) by_island.row_start[si + 1] += by_island.row_start[si];
    by_island.order.resize(static_cast<size_t>(by_island.row_start.back()));
    std::vector<Index> cursor(by_island.row_start.begin(), by_island.row_start.end() - 1);
    for (Index k = 0; k < col.colours(); ++k) {
      for (Index t = col.row_start[k]; t < col.row_start[k + 1]; ++t) {
        const Index c = col.order[t];
        const Index si = small_index[island_of_key[key(batch, c)]];
        if (si >= 0)
          by_island.order[cursor[si]++] = c;
        else
          large_col.order.push_back(c);
      }
      const Index n = static_cast<Index>(large_col.order.size());
      if (n > large_col.row_start.back()) large_col.row_start.push_back(n);
    }
  }
}

void MaterialSystem::reset_multipliers() {
  for (Stage& s : stages_) s.batch->reset_multipliers();
}

void MaterialSystem::solve(Positions& x, std::span<const double> inv_mass, double dt) {
  // Small islands: one serial task each, in parallel. They share no dynamic vertex with each other
  // or with the large islands, so neither the task order nor the thread count changes the result.
  parallel_for(
      small_islands_,
      [&](Index lo, Index hi) {
        for (Index i = lo; i < hi; ++i)
          for (Stage& s : stages_) s.batch->solve_in_order(s.small.island(i), x, inv_mass, dt);
      },
      1);
  for (Stage& s : stages_) s.batch->solve(s.large, x, inv_mass, dt);
  rigid_.solve(x, inv_mass);
}

void MaterialSystem::solve_by_colour(Positions& x, std::span<const double> inv_mass, double dt) {
  for (Stage& s : stages_) s.batch->solve(x, inv_mass, dt);
  rigid_.solve(x, inv_mass);
}

const ConstraintBatch* MaterialSystem::batch(std::string_view name) const {
  for (const Stage& s : stages_)
    if (s.name == name) return s.batch.get();
  return nullptr;
}

template <class B>
const B& MaterialSystem::builtin(std::string_view name) const {
  static const B empty;
  const auto* b = dynamic_cast<const B*>(batch(name));
  return b ? *b : empty;
}

const DistanceBatch& MaterialSystem::distance() const { return builtin<DistanceBatch>("stretch"); }
const BendingBatch& MaterialSystem::bending() const { return builtin<BendingBatch>("dihedral_bending"); }
const StrandBendingBatch& MaterialSystem::strand_bending() const {
  return builtin<StrandBendingBatch>("strand_bending");
}
const TetBatch& MaterialSystem::tets() const { return builtin<TetBatch>("tet_elasticity"); }

MaterialSystem::Counts MaterialSystem::counts() const {
  Counts c;
  c.distance = distance().size();
  c.bending = bending().size();
  c.strand_bending = strand_bending().size();
  c.tet_volume = tets().size();
  c.tet_deviatoric = tets().size();
  c.rigid_bodies = rigid_.size();
  for (const Stage& s : stages_) {
    c.colours += s.batch->colouring.colours();
    c.by_name.emplace_back(s.name, s.batch->size());
  }
  c.small_islands = small_islands_;
  c.large_islands = large_islands_;
  return c;
}

}  // namespace ccfr
