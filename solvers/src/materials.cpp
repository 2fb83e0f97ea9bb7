#include "ccfr/solvers/materials.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include <Eigen/LU>
#include <Eigen/SVD>

#include "ccfr/core/log.hpp"
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

namespace {

/// A colour of a bending, strand-bending or tet batch is split into parallel tasks only beyond
/// this many constraints; smaller colours run inline on the calling thread.
constexpr Index kConstraintGrain = 256;

/// One sweep of `batch` over `col`: colours in sequence, each colour's constraints (which share no
/// dynamic vertex) in parallel.
template <class Batch>
void solve_coloured(Batch& batch, const Colouring& col, Positions& x, std::span<const double> w, double dt) {
  const std::span<const Index> order(col.order);
  for (Index k = 0; k < col.colours(); ++k) {
    const Index b = col.row_start[k], e = col.row_start[k + 1];
    parallel_for(
        e - b,
        [&](Index lo, Index hi) {
          batch.solve_in_order(order.subspan(static_cast<size_t>(b + lo), static_cast<size_t>(hi - lo)), x, w, dt);
        },
        kConstraintGrain);
  }
}

template <int N>
Colouring colour(const std::vector<Eigen::Matrix<Index, N, 1>>& ids, Index num_vertices,
                 std::span<const double> inv_mass) {
  return colour_constraints(num_vertices, {ids.empty() ? nullptr : ids.front().data(), ids.size() * N}, N, inv_mass);
}

}  // namespace

// ---- BendingBatch -------------------------------------------------------------------------------

void BendingBatch::add(const Vec4i& v, double theta0, double alpha) {
  ids.push_back(v);
  rest_angle.push_back(theta0);
  compliance.push_back(alpha);
  lambda.push_back(0.0);
}

void BendingBatch::finalize(Index num_vertices, std::span<const double> inv_mass) {
  colouring = colour<4>(ids, num_vertices, inv_mass);
}

void BendingBatch::reset_multipliers() { std::fill(lambda.begin(), lambda.end(), 0.0); }

void BendingBatch::solve(const Colouring& col, Positions& x, std::span<const double> w, double dt) {
  solve_coloured(*this, col, x, w, dt);
}

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

void StrandBendingBatch::finalize(Index num_vertices, std::span<const double> inv_mass) {
  colouring = colour<3>(ids, num_vertices, inv_mass);
}

void StrandBendingBatch::reset_multipliers() { std::fill(lambda.begin(), lambda.end(), 0.0); }

void StrandBendingBatch::solve(const Colouring& col, Positions& x, std::span<const double> w, double dt) {
  solve_coloured(*this, col, x, w, dt);
}

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

void TetBatch::finalize(Index num_vertices, std::span<const double> inv_mass) {
  colouring = colour<4>(ids, num_vertices, inv_mass);
}

void TetBatch::reset_multipliers() {
  std::fill(lambda_volume.begin(), lambda_volume.end(), 0.0);
  std::fill(lambda_deviatoric.begin(), lambda_deviatoric.end(), 0.0);
}

void TetBatch::solve(const Colouring& col, Positions& x, std::span<const double> w, double dt) {
  solve_coloured(*this, col, x, w, dt);
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

MaterialSystem::MaterialSystem(const Topology& topo, const SimState& state, const SimulationParams& params) {
  if (params.objects.size() != topo.objects.size())
    throw std::logic_error("MaterialSystem: params.objects has " + std::to_string(params.objects.size()) +
                           " entries for " + std::to_string(topo.objects.size()) + " objects");
  const auto& rest = state.rest;
  const std::span<const double> inv_mass = state.inv_mass;
  const Index nv = topo.num_vertices();

  // Edges by object kind, one pass over the global edge array (edge order kept for determinism).
  for (Index e = 0; e < topo.num_edges(); ++e) {
    const Index oi = topo.edge_object[e];
    switch (topo.objects[oi].kind) {
      case ObjectKind::cloth:
      case ObjectKind::shell:
      case ObjectKind::strand: {
        const Index i = topo.edges[e][0], j = topo.edges[e][1];
        distance_.add(i, j, (rest[i] - rest[j]).norm(), params.objects[oi].material.stretch_compliance);
        break;
      }
      default:
        break;
    }
  }

  // Interior edges of cloth and shells: the two faces incident to an edge, from face_edges.
  // Boundary edges (one face) get no bending; non-manifold edges (three or more faces) are skipped
  // because no single dihedral angle describes them.
  std::vector<Index> edge_face_count(static_cast<size_t>(topo.num_edges()), 0);
  std::vector<Vec2i> edge_faces(static_cast<size_t>(topo.num_edges()), Vec2i(-1, -1));
  for (Index f = 0; f < topo.num_faces(); ++f) {
    const auto kind = topo.objects[topo.face_object[f]].kind;
    if (kind != ObjectKind::cloth && kind != ObjectKind::shell) continue;
    for (int k = 0; k < 3; ++k) {
      const Index e = topo.face_edges[f][k];
      if (edge_face_count[e] < 2) edge_faces[e][edge_face_count[e]] = f;
      ++edge_face_count[e];
    }
  }
  Index skipped_bending = 0;
  for (Index e = 0; e < topo.num_edges(); ++e) {
    if (edge_face_count[e] != 2) continue;
    const Index a = topo.edges[e][0], b = topo.edges[e][1];
    auto opposite = [&](Index f) {
      const Vec3i& t = topo.faces[f];
      for (int k = 0; k < 3; ++k)
        if (t[k] != a && t[k] != b) return t[k];
      return Index{-1};
    };
    const Index c = opposite(edge_faces[e][0]), d = opposite(edge_faces[e][1]);
    std::array<Vec3, 4> g;
    double theta0 = 0.0;
    if (c < 0 || d < 0 || c == d || !xpbd::dihedral_angle_gradient(rest[a], rest[b], rest[c], rest[d], theta0, g)) {
      ++skipped_bending;
      continue;
    }
    bending_.add(Vec4i(a, b, c, d), theta0, params.objects[topo.edge_object[e]].material.bend_compliance);
  }

  for (size_t oi = 0; oi < topo.objects.size(); ++oi) {
    const auto& o = topo.objects[oi];
    const auto& mat = params.objects[oi].material;
    if (o.kind == ObjectKind::strand) {
      for (Index p = o.polyline_begin; p < o.polyline_end; ++p) {
        const auto row = topo.polylines.row(p);
        for (size_t k = 1; k + 1 < row.size(); ++k) {
          const Vec3i v(row[k - 1], row[k], row[k + 1]);
          strand_bending_.add(v, xpbd::turning_angle(rest[v[0]], rest[v[1]], rest[v[2]]), mat.bend_compliance);
        }
      }
    } else if (o.kind == ObjectKind::tet_solid) {
      Index skipped = 0;
      for (Index t = o.tet_begin; t < o.tet_end; ++t)
        if (!tets_.add(topo.tets[t], rest, mat.volume_compliance, mat.shear_compliance)) ++skipped;
      if (skipped > 0) log::warn("object '{}': {} degenerate rest tets get no material constraint", o.name, skipped);
    } else if (o.kind == ObjectKind::rigid && o.num_vertices() > 0) {
      rigid_.add(o.vertex_begin, o.vertex_end, rest, inv_mass);
    }
  }
  if (skipped_bending > 0)
    log::warn("{} interior edges with degenerate rest triangles get no bending constraint", skipped_bending);

  distance_.finalize(nv, inv_mass);
  bending_.finalize(nv, inv_mass);
  strand_bending_.finalize(nv, inv_mass);
  tets_.finalize(nv, inv_mass);
  build_schedule(nv, inv_mass);
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
  auto link = [&](const auto& batch) {
    for (Index c = 0; c < batch.size(); ++c) {
      const auto& v = batch.ids[c];
      Index first = -1;
      for (int a = 0; a < static_cast<int>(v.size()); ++a) {
        if (inv_mass[v[a]] == 0.0) continue;
        if (first < 0)
          first = v[a];
        else
          uf.unite(first, v[a]);
      }
    }
  };
  link(distance_), link(bending_), link(strand_bending_), link(tets_);
  auto key = [&](const auto& batch, Index c) {
    const auto& v = batch.ids[c];
    for (int a = 0; a < static_cast<int>(v.size()); ++a)
      if (inv_mass[v[a]] != 0.0) return uf.find(v[a]);
    return v[0];
  };

  // Island ids in order of first appearance (batches in sweep order, constraints in colour order).
  std::vector<Index> island_of_key(static_cast<size_t>(nv), -1);
  Index num_islands = 0;
  std::vector<char> large;
  std::vector<double> cost;
  std::vector<Index> colour_count;  // per island, constraints in the current colour
  auto scan = [&](const auto& batch, Index grain, double unit_cost) {
    const Colouring& col = batch.colouring;
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
  };
  // Unit costs: rough relative kernel costs, used only to start the largest small islands first.
  scan(distance_, kDistanceGrain, 1.0);
  scan(bending_, kConstraintGrain, 4.0);
  scan(strand_bending_, kConstraintGrain, 3.0);
  scan(tets_, kConstraintGrain, 10.0);

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

  auto split = [&](const auto& batch, IslandOrder& by_island, Colouring& large_col) {
    const Colouring& col = batch.colouring;
    by_island.row_start.assign(static_cast<size_t>(small_islands_) + 1, 0);
    by_island.order.clear();
    large_col = Colouring{};
    large_col.row_start.push_back(0);
    for (Index t = 0; t < static_cast<Index>(col.order.size()); ++t) {
      const Index s = small_index[island_of_key[key(batch, col.order[t])]];
      if (s >= 0) ++by_island.row_start[s + 1];
    }
    for (Index s = 0; s < small_islands_; ++s) by_island.row_start[s + 1] += by_island.row_start[s];
    by_island.order.resize(static_cast<size_t>(by_island.row_start.back()));
    std::vector<Index> cursor(by_island.row_start.begin(), by_island.row_start.end() - 1);
    for (Index k = 0; k < col.colours(); ++k) {
      for (Index t = col.row_start[k]; t < col.row_start[k + 1]; ++t) {
        const Index c = col.order[t];
        const Index s = small_index[island_of_key[key(batch, c)]];
        if (s >= 0)
          by_island.order[cursor[s]++] = c;
        else
          large_col.order.push_back(c);
      }
      const Index n = static_cast<Index>(large_col.order.size());
      if (n > large_col.row_start.back()) large_col.row_start.push_back(n);
    }
  };
  split(distance_, small_distance_, large_distance_);
  split(bending_, small_bending_, large_bending_);
  split(strand_bending_, small_strand_, large_strand_);
  split(tets_, small_tets_, large_tets_);
}

void MaterialSystem::reset_multipliers() {
  distance_.reset_multipliers();
  bending_.reset_multipliers();
  strand_bending_.reset_multipliers();
  tets_.reset_multipliers();
}

void MaterialSystem::solve(Positions& x, std::span<const double> inv_mass, double dt) {
  // Small islands: one serial task each, in parallel. They share no dynamic vertex with each other
  // or with the large islands, so neither the task order nor the thread count changes the result.
  parallel_for(
      small_islands_,
      [&](Index lo, Index hi) {
        for (Index i = lo; i < hi; ++i) {
          distance_.solve_in_order(small_distance_.island(i), x, inv_mass, dt);
          bending_.solve_in_order(small_bending_.island(i), x, inv_mass, dt);
          strand_bending_.solve_in_order(small_strand_.island(i), x, inv_mass, dt);
          tets_.solve_in_order(small_tets_.island(i), x, inv_mass, dt);
        }
      },
      1);
  distance_.solve(large_distance_, x, inv_mass, dt);
  bending_.solve(large_bending_, x, inv_mass, dt);
  strand_bending_.solve(large_strand_, x, inv_mass, dt);
  tets_.solve(large_tets_, x, inv_mass, dt);
  rigid_.solve(x, inv_mass);
}

void MaterialSystem::solve_by_colour(Positions& x, std::span<const double> inv_mass, double dt) {
  distance_.solve(x, inv_mass, dt);
  bending_.solve(x, inv_mass, dt);
  strand_bending_.solve(x, inv_mass, dt);
  tets_.solve(x, inv_mass, dt);
  rigid_.solve(x, inv_mass);
}

MaterialSystem::Counts MaterialSystem::counts() const {
  Counts c;
  c.distance = distance_.size();
  c.bending = bending_.size();
  c.strand_bending = strand_bending_.size();
  c.tet_volume = tets_.size();
  c.tet_deviatoric = tets_.size();
  c.rigid_bodies = rigid_.size();
  c.colours = distance_.colouring.colours() + bending_.colouring.colours() + strand_bending_.colouring.colours() +
              tets_.colouring.colours();
  c.small_islands = small_islands_;
  c.large_islands = large_islands_;
  return c;
}

}  // namespace ccfr
