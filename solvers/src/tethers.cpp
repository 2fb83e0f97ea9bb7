#include "ccfr/solvers/tethers.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <queue>
#include <span>

#include <Eigen/Eigenvalues>

#include "ccfr/core/parallel.hpp"
#include "ccfr/solvers/params.hpp"

namespace ccfr {

namespace {
/// Tethers per vertex and pin group on a flat convex sheet (the nearest pins).
constexpr int kPinsPerGroup = 4;
/// Most rounds of cyclic projection onto a vertex's tether balls.
constexpr int kRounds = 16;
/// Most tethers of a vertex projected onto exactly (their triples are searched).
constexpr Index kMostExact = 8;

/// A flat sheet that is its convex hull: its rest vertices lie in one plane (within 1e-9 of its
/// extent), its triangles' area is the area of their 2D convex hull and its boundary edges' length
/// the hull's perimeter (within 1e-9), so no hole, notch, slit or seam lies between two of its
/// points and the straight rest distance is the geodesic.
bool is_flat_and_convex(const Topology& topo, const ObjectInfo& o, const Positions& rest) {
  const Index begin = o.vertex_begin, end = o.vertex_end;
  if (end - begin < 3 || o.face_end <= o.face_begin) return false;
  Vec3 c = Vec3::Zero();
  for (Index v = begin; v < end; ++v) c += rest[v];
  c /= double(end - begin);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  double extent = 0.0;
  for (Index v = begin; v < end; ++v) {
    const Vec3 d = rest[v] - c;
    cov += d * d.transpose();
    extent = std::max(extent, d.norm());
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  const Vec3 n = eig.eigenvectors().col(0), e1 = eig.eigenvectors().col(1), e2 = eig.eigenvectors().col(2);
  for (Index v = begin; v < end; ++v)
    if (std::abs(n.dot(rest[v] - c)) > 1e-9 * extent) return false;
  double area = 0.0;
  for (Index f = o.face_begin; f < o.face_end; ++f) {
    const Vec3i& t = topo.faces[f];
    area += 0.5 * (rest[t[1]] - rest[t[0]]).cross(rest[t[2]] - rest[t[0]]).norm();
  }
  // Andrew's monotone chain on the plane's coordinates.
  std::vector<Eigen::Vector2d> p;
  for (Index v = begin; v < end; ++v) p.emplace_back(e1.dot(rest[v] - c), e2.dot(rest[v] - c));
  std::sort(p.begin(), p.end(),
            [](const auto& a, const auto& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); });
  auto cross = [](const Eigen::Vector2d& o2, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a.x() - o2.x()) * (b.y() - o2.y()) - (a.y() - o2.y()) * (b.x() - o2.x());
  };
  std::vector<Eigen::Vector2d> hull(2 * p.size());
  size_t k = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], p[i]) <= 0.0) --k;
    hull[k++] = p[i];
  }
  for (size_t i = p.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && cross(hull[k - 2], hull[k - 1], p[i]) <= 0.0) --k;
    hull[k++] = p[i];
  }
  double hull_area = 0.0, hull_perimeter = 0.0;
  for (size_t i = 0; i + 1 < k; ++i) {
    hull_area += 0.5 * (hull[i].x() * hull[i + 1].y() - hull[i + 1].x() * hull[i].y());
    hull_perimeter += (hull[i + 1] - hull[i]).norm();
  }
  // A slit, an unwelded seam or two panels side by side cover the hull too, but add boundary: the
  // sheet's boundary edges (one face each) must add up to the hull's perimeter.
  std::vector<int> faces_of_edge(topo.edges.size(), 0);
  for (Index f = o.face_begin; f < o.face_end; ++f)
    for (int j = 0; j < 3; ++j) ++faces_of_edge[static_cast<size_t>(topo.face_edges[f][j])];
  double boundary = 0.0;
  for (size_t e = 0; e < topo.edges.size(); ++e)
    if (faces_of_edge[e] == 1) boundary += (rest[topo.edges[e][0]] - rest[topo.edges[e][1]]).norm();
  const double tol = 1e-9;
  return std::abs(hull_area - area) <= tol * std::max(hull_area, area) &&
         std::abs(hull_perimeter - boundary) <= tol * std::max(hull_perimeter, boundary);
}
}  // namespace

Tethers::Tethers(const Topology& topo, const SimState& state, const SimulationParams& params) {
  if (!params.contact.momentum || !params.contact.tethers) return;
  const double slack = params.contact.tether_slack;
  const Index nv = topo.num_vertices();
  std::vector<std::vector<std::pair<Index, double>>> per_vertex(static_cast<size_t>(nv));
  std::vector<double> dist;
  std::vector<Index> source;
  std::vector<std::pair<double, Index>> near;
  for (size_t oi = 0; oi < topo.objects.size() && oi < params.objects.size(); ++oi) {
    const auto& o = topo.objects[oi];
    if (o.kind != ObjectKind::cloth && o.kind != ObjectKind::strand) continue;
    const bool flat = o.kind == ObjectKind::cloth && is_flat_and_convex(topo, o, state.rest);
    for (const PinGroup& group : params.objects[oi].pins) {
      // A scripted group may pull its pins farther apart than the cloth between them reaches (the
      // twisting cloth's handles): the bound holds only for pins that stay where they rest.
      if (group.motion.moves()) continue;
      if (flat) {
        for (Index v = o.vertex_begin; v < o.vertex_end; ++v) {
          if (!(state.inv_mass[v] > 0.0)) continue;
          near.clear();
          for (Index lv : group.vertices) {
            const Index p = o.vertex_begin + lv;
            near.push_back({(state.rest[v] - state.rest[p]).norm(), p});
          }
          const size_t k = std::min<size_t>(kPinsPerGroup, near.size());
          std::partial_sort(near.begin(), near.begin() + static_cast<std::ptrdiff_t>(k), near.end());
          for (size_t j = 0; j < k; ++j)
            if (near[j].first > 0.0) per_vertex[v].push_back({near[j].second, near[j].first * (1.0 + slack)});
        }
        continue;
      }
      // Multi-source Dijkstra over the object's rest edges from the group's vertices: a strand's
      // arc length; on a curved sheet a path along edges, never shorter than the geodesic.
      dist.assign(static_cast<size_t>(nv), std::numeric_limits<double>::infinity());
      source.assign(static_cast<size_t>(nv), -1);
      using Item = std::pair<double, Index>;
      std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
      for (Index lv : group.vertices) {
        const Index v = o.vertex_begin + lv;
        dist[v] = 0.0, source[v] = v;
        queue.push({0.0, v});
      }
      while (!queue.empty()) {
        const auto [d, v] = queue.top();
        queue.pop();
        if (d > dist[v]) continue;
        for (Index e : topo.vertex_edges.row(v)) {
          const Index u = topo.edges[e][0] == v ? topo.edges[e][1] : topo.edges[e][0];
          const double du = d + (state.rest[u] - state.rest[v]).norm();
          if (du < dist[u]) dist[u] = du, source[u] = source[v], queue.push({du, u});
        }
      }
      for (Index v = o.vertex_begin; v < o.vertex_end; ++v)
        if (state.inv_mass[v] > 0.0 && source[v] >= 0 && dist[v] > 0.0)
          per_vertex[v].push_back({source[v], dist[v] * (1.0 + slack)});
    }
  }
  start_.assign(static_cast<size_t>(nv) + 1, 0);
  for (Index v = 0; v < nv; ++v) {
    start_[v + 1] = start_[v] + static_cast<Index>(per_vertex[v].size());
    for (const auto& [p, l] : per_vertex[v]) pin_.push_back(p), length_.push_back(l);
  }
  if (pin_.empty()) start_.clear();
}

Index Tethers::enforce(Positions& x, std::span<const double> inv_mass) const {
  if (empty()) return 0;
  std::atomic<Index> moved{0};
  parallel_for(
      static_cast<Index>(start_.size()) - 1,
      [&](Index b, Index e) {
        Index mine = 0;
        for (Index v = b; v < e; ++v)
          if (inv_mass[v] > 0.0) mine += cap(x, v);
        moved += mine;
      },
      1024);
  return moved.load();
}

namespace {
struct Ball {
  Vec3 c;
  double r;
};

/// Relative tolerance of the ball tests: with slack 0 a vertex between two pins has balls that
/// only touch, and rounding must not part them.
constexpr double kBallTolerance = 1e-10;

bool inside_all(const Vec3& p, std::span<const Ball> balls) {
  for (const Ball& b : balls)
    if ((p - b.c).norm() > b.r * (1.0 + kBallTolerance)) return false;
  return true;
}

/// The point of the intersection of `balls` nearest q (KKT: it lies on the boundary of at most
/// three of them: the nearest point of one sphere, of two spheres' circle, or one of three spheres'
/// two common points, inside the others); false where the intersection is empty.
bool project_onto_balls(const Vec3& q, std::span<const Ball> balls, Vec3& out) {
  if (inside_all(q, balls)) return out = q, true;
  double best = std::numeric_limits<double>::infinity();
  auto consider = [&](const Vec3& p) {
    const double d = (p - q).squaredNorm();
    if (d < best && inside_all(p, balls)) best = d, out = p;
  };
  const size_t n = balls.size();
  for (size_t i = 0; i < n; ++i) {
    const Vec3 d = q - balls[i].c;
    if (d.norm() > 0.0) consider(balls[i].c + d * (balls[i].r / d.norm()));
  }
  // Circle of spheres i and j: centre m on the axis u, radius h.
  auto circle = [&](size_t i, size_t j, Vec3& m, Vec3& u, double& h) {
    const Vec3 axis = balls[j].c - balls[i].c;
    const double d = axis.norm();
    const double slop = kBallTolerance * std::max(balls[i].r, balls[j].r);
    if (!(d > 0.0) || d > balls[i].r + balls[j].r + slop || d < std::abs(balls[i].r - balls[j].r) - slop) return false;
    u = axis / d;
    const double a = (d * d + balls[i].r * balls[i].r - balls[j].r * balls[j].r) / (2.0 * d);
    h = std::sqrt(std::max(0.0, balls[i].r * balls[i].r - a * a));
    m = balls[i].c + a * u;
    return true;
  };
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j) {
      Vec3 m, u;
      double h;
      if (!circle(i, j, m, u, h)) continue;
      Vec3 w = (q - m) - (q - m).dot(u) * u;
      if (!(w.norm() > 0.0)) w = u.unitOrthogonal();
      consider(m + h * w.normalized());
      // Three spheres: the circle of i and j meets sphere k in at most two points.
      for (size_t k = j + 1; k < n; ++k) {
        // Points m + h (cos t e1 + sin t e2) at distance r_k from c_k: a cos t + b sin t = c.
        const Vec3 e1 = u.unitOrthogonal(), e2 = u.cross(e1);
        const Vec3 g = m - balls[k].c;
        const double a = 2.0 * h * g.dot(e1), b = 2.0 * h * g.dot(e2);
        const double c = balls[k].r * balls[k].r - g.squaredNorm() - h * h;
        const double rho = std::hypot(a, b);
        if (!(rho > 0.0) || std::abs(c) > rho * (1.0 + kBallTolerance)) continue;
        const double phi = std::atan2(b, a), delta = std::acos(std::clamp(c / rho, -1.0, 1.0));
        for (const double t : {phi + delta, phi - delta}) consider(m + h * (std::cos(t) * e1 + std::sin(t) * e2));
      }
    }
  return std::isfinite(best);
}
}  // namespace

bool Tethers::cap(Positions& x, Index v) const {
  if (v < 0 || v + 1 >= static_cast<Index>(start_.size()) || start_[v] == start_[v + 1]) return false;
  Ball balls[kMostExact];
  const Index n = start_[v + 1] - start_[v];
  for (Index t = 0; t < std::min<Index>(n, kMostExact); ++t)
    balls[t] = {x[pin_[start_[v] + t]], length_[start_[v] + t]};
  if (inside_all(x[v], std::span<const Ball>(balls, static_cast<size_t>(std::min<Index>(n, kMostExact)))) &&
      n <= kMostExact)
    return false;
  Vec3 p = Vec3::Zero();
  if (n <= kMostExact && project_onto_balls(x[v], std::span<const Ball>(balls, static_cast<size_t>(n)), p)) {
    x[v] = p;
    return true;
  }
  // More tethers than the exact search takes, or balls that no longer meet (pins pulled apart):
  // cyclic projection onto each ball in turn.
  bool any = false;
  for (int round = 0; round < kRounds; ++round) {
    bool exceeded = false;
    for (Index t = start_[v]; t < start_[v + 1]; ++t) {
      const Vec3 d = x[v] - x[pin_[t]];
      const double len = d.norm();
      if (len > length_[t] * (1.0 + 1e-12)) x[v] = x[pin_[t]] + d * (length_[t] / len), exceeded = true;
    }
    any = any || exceeded;
    if (!exceeded) break;
  }
  return any;
}

double Tethers::share(const Positions& x, Index v, const Vec3& d) const {
  const double dn = d.norm();
  if (!(dn > 0.0)) return 0.0;
  Vec3 left = d / dn;
  // Gram-Schmidt over the reached tethers' normals: at most three are independent.
  Vec3 basis[3];
  int k = 0;
  for (Index t = v >= 0 && v + 1 < static_cast<Index>(start_.size()) ? start_[v] : 0;
       v >= 0 && v + 1 < static_cast<Index>(start_.size()) && t < start_[v + 1] && k < 3; ++t) {
    const Vec3 r = x[v] - x[pin_[t]];
    const double len = r.norm();
    if (!(len >= length_[t] * (1.0 - 1e-9)) || !(len > 0.0)) continue;
    Vec3 m = r / len;
    for (int i = 0; i < k; ++i) m -= m.dot(basis[i]) * basis[i];
    if (m.norm() <= 1e-9) continue;  // dependent on the ones before
    basis[k++] = m.normalized();
  }
  for (int i = 0; i < k; ++i) left -= left.dot(basis[i]) * basis[i];
  return left.squaredNorm();
}

}  // namespace ccfr
