#include "ccfr/geometry/mass_properties.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace ccfr {

SolidMassProperties solid_mass_properties(std::span<const Vec3> v, std::span<const Vec3i> faces) {
  SolidMassProperties p;
  if (v.empty() || faces.empty()) return p;
  // Reference point at the vertex mean: the tets stay small, so cancellation stays small.
  Vec3 o = Vec3::Zero();
  for (const Vec3& x : v) o += x;
  o /= static_cast<double>(v.size());
  double vol = 0.0;
  Vec3 first = Vec3::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (const Vec3i& f : faces) {
    const Vec3 a = v[f[0]] - o, b = v[f[1]] - o, c = v[f[2]] - o;
    const double vt = a.dot(b.cross(c)) / 6.0;  // signed volume of the tet (o, a, b, c)
    const Vec3 s = a + b + c;
    vol += vt;
    first += vt * s / 4.0;
    second += vt / 20.0 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
  }
  if (vol == 0.0) return p;
  p.inverted = vol < 0.0;
  const Vec3 c = first / vol;  // the sign of vol cancels
  p.volume = std::abs(vol);
  p.centroid = o + c;
  // Parallel-axis shift from o to the centroid; an inward winding negates every moment alike.
  p.second_moment = (vol < 0.0 ? -1.0 : 1.0) * second - p.volume * c * c.transpose();
  p.second_moment = 0.5 * (p.second_moment + p.second_moment.transpose()).eval();
  return p;
}

namespace {

/// min Σ dᵢ (wᵢ - tᵢ)² subject to A w = b and w >= 0: the equality-constrained minimiser on the free
/// set (its multipliers λ from the m×m system A_F D⁻¹ A_Fᵀ λ = b - A_F t, pseudo-inverted because
/// the rows are dependent whenever the points lie on a quadric, e.g. a box's corners), variables that
/// go negative fixed at 0, fixed ones with a negative bound multiplier released. Returns max |A w - b|.
double least_change_nonnegative(const Eigen::MatrixXd& a, const Eigen::VectorXd& b, const Eigen::VectorXd& t,
                                const Eigen::VectorXd& d, Eigen::VectorXd& w) {
  const Eigen::Index n = t.size(), m = b.size();
  std::vector<char> fixed(static_cast<size_t>(n), 0);
  w = t;
  const int max_iterations = 500;
  for (int it = 0; it < max_iterations; ++it) {
    Eigen::MatrixXd k = Eigen::MatrixXd::Zero(m, m);
    Eigen::VectorXd r = b;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (fixed[i]) continue;
      k.noalias() += a.col(i) * a.col(i).transpose() / d[i];
      r -= a.col(i) * t[i];
    }
    const Eigen::VectorXd lambda = k.completeOrthogonalDecomposition().solve(r);
    const Eigen::VectorXd at_lambda = a.transpose() * lambda;
    bool negative = false;
    for (Eigen::Index i = 0; i < n; ++i) {
      w[i] = fixed[i] ? 0.0 : t[i] + at_lambda[i] / d[i];
      if (!fixed[i] && w[i] < 0.0) {
        fixed[i] = 1;
        negative = true;
      }
    }
    if (negative) continue;
    // KKT for a fixed variable: its bound multiplier μ = -dᵢtᵢ - (Aᵀλ)ᵢ must be >= 0.
    Eigen::Index release = -1;
    double worst = -1e-12;
    for (Eigen::Index i = 0; i < n; ++i)
      if (fixed[i]) {
        const double mu = (-d[i] * t[i] - at_lambda[i]) * t[i];  // scaled by tᵢ: relative
        if (mu < worst) worst = mu, release = i;
      }
    if (release < 0) break;
    fixed[release] = 0;
  }
  for (Eigen::Index i = 0; i < n; ++i) w[i] = std::max(w[i], 0.0);
  return (a * w - b).cwiseAbs().maxCoeff();
}

}  // namespace

RigidVertexMasses rigid_vertex_masses(std::span<const Vec3> v, std::span<const Vec3i> faces, double rho,
                                      const SolidMassProperties& props) {
  const Eigen::Index n = static_cast<Eigen::Index>(v.size());
  const double mass = rho * props.volume;
  RigidVertexMasses out;
  out.vertex.assign(v.size(), n > 0 ? mass / static_cast<double>(n) : 0.0);
  if (n == 0 || !(mass > 0.0)) return out;
  const Eigen::Matrix3d s = props.second_moment / props.volume;  // per unit mass (m²)
  const double len2 = std::max(s.trace(), 1e-300);               // squared radius of gyration
  const double len = std::sqrt(len2);

  // Area-lumped targets: a third of every face's area on each of its vertices.
  Eigen::VectorXd area = Eigen::VectorXd::Zero(n);
  for (const Vec3i& f : faces) {
    const double a = 0.5 * (v[f[1]] - v[f[0]]).cross(v[f[2]] - v[f[0]]).norm() / 3.0;
    for (int k = 0; k < 3; ++k) area[f[k]] += a;
  }
  const double area_sum = area.sum();
  if (!(area_sum > 0.0)) return out;
  area /= area_sum;
  area = area.cwiseMax(1e-6 / static_cast<double>(n));
  area /= area.sum();

  // Rows in units of the body: masses / mass, offsets / radius of gyration.
  Eigen::MatrixXd a(10, n + 1);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(10);
  double spread = 0.0;  // Σ areaᵢ |qᵢ|² / len²
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 q = (v[static_cast<size_t>(i)] - props.centroid) / len;
    spread += area[i] * q.squaredNorm();
    a.col(i) << 1.0, q.x(), q.y(), q.z(), q.x() * q.x(), q.y() * q.y(), q.z() * q.z(), q.x() * q.y(), q.x() * q.z(),
        q.y() * q.z();
  }
  a.col(n) << 1.0, 0, 0, 0, 0, 0, 0, 0, 0, 0;  // the core: mass only
  const Eigen::Matrix3d sn = s / len2;
  b << 1.0, 0, 0, 0, sn(0, 0), sn(1, 1), sn(2, 2), sn(0, 1), sn(0, 2), sn(1, 2);
  // Targets: a surface share whose second moment has the right trace (1 / spread), the rest in the core.
  const double surface = std::clamp(1.0 / std::max(spread, 1e-300), 1e-3, 0.9);
  Eigen::VectorXd t(n + 1), d(n + 1), w;
  t.head(n) = surface * area;
  t[n] = 1.0 - surface;
  d = t.cwiseProduct(t).cwiseInverse();  // relative change
  constexpr double kExact = 1e-9;
  // Every vertex keeps at least 1e-3 of its target where possible (w = least + u, u >= 0): a vertex
  // of no mass would be deaf to contact in the body's fits.
  const Eigen::VectorXd least = 1e-3 * t;
  Eigen::VectorXd u;
  double residual = least_change_nonnegative(a, b - a * least, t - least, d, u);
  w = least + u;
  if (residual > kExact) residual = least_change_nonnegative(a, b, t, d, w);
  if (residual <= kExact) {
    out.exact = true;
    for (Eigen::Index i = 0; i < n; ++i) out.vertex[static_cast<size_t>(i)] = mass * w[i];
    out.core = mass * w[n];
    return out;
  }
  // Fallback: no core, total mass and centre of mass only (always reachable: the centre of mass of
  // a solid lies in the convex hull of its vertices).
  const Eigen::MatrixXd a4 = a.topLeftCorner(4, n);
  const Eigen::VectorXd b4 = b.head(4);
  const Eigen::VectorXd t4 = area, d4 = area.cwiseProduct(area).cwiseInverse();
  residual = least_change_nonnegative(a4, b4, t4, d4, w);
  if (residual <= kExact)
    for (Eigen::Index i = 0; i < n; ++i) out.vertex[static_cast<size_t>(i)] = mass * w[i];
  // else: equal masses (the vertex centroid), as reported by inertia_error and a centre off the solid's.
  Eigen::Matrix3d sm = Eigen::Matrix3d::Zero();
  Vec3 c = Vec3::Zero();
  double total = 0.0;
  for (size_t i = 0; i < v.size(); ++i) {
    total += out.vertex[i];
    c += out.vertex[i] * v[i];
  }
  c /= total;
  for (size_t i = 0; i < v.size(); ++i) sm += out.vertex[i] * (v[i] - c) * (v[i] - c).transpose();
  const Eigen::Matrix3d im = sm.trace() * Eigen::Matrix3d::Identity() - sm;
  const Eigen::Matrix3d is = props.inertia(rho);
  out.inertia_error = (im - is).norm() / is.norm();
  return out;
}

}  // namespace ccfr
