#include "ccfr/geometry/generators.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <stdexcept>
#include <string>

namespace ccfr::gen {

namespace {
/// Element counts are computed in 64 bits and must fit `Index` (int32): beyond it the index
/// arithmetic would wrap and the mesh would address memory it does not own.
void check_count(long long n, const char* what, const std::string& shape) {
  if (n > std::numeric_limits<Index>::max())
    throw std::invalid_argument(shape + " makes " + std::to_string(n) + " " + what + ", more than the " +
                                std::to_string(std::numeric_limits<Index>::max()) + " that 32-bit indices address");
}
}  // namespace

TriMesh grid(double size_x, double size_z, Index res_x, Index res_z) {
  if (res_x < 1 || res_z < 1) throw std::invalid_argument("grid resolution must be >= 1");
  const std::string what = "grid resolution [" + std::to_string(res_x) + ", " + std::to_string(res_z) + "]";
  check_count((res_x + 1LL) * (res_z + 1LL), "vertices", what);
  check_count(2LL * res_x * res_z, "faces", what);
  TriMesh m;
  const Index nx = res_x + 1, nz = res_z + 1;
  m.v.reserve(static_cast<size_t>(nx) * nz);
  for (Index j = 0; j < nz; ++j)
    for (Index i = 0; i < nx; ++i)
      m.v.emplace_back(size_x * (double(i) / res_x - 0.5), 0.0, size_z * (double(j) / res_z - 0.5));
  for (Index j = 0; j < res_z; ++j)
    for (Index i = 0; i < res_x; ++i) {
      const Index a = j * nx + i, b = a + 1, c = a + nx, d = c + 1;
      // Normal +y: (c - a) x (b - a) points up for x right, z forward.
      if ((i + j) % 2 == 0) {
        m.f.emplace_back(a, c, b);
        m.f.emplace_back(b, c, d);
      } else {
        m.f.emplace_back(a, c, d);
        m.f.emplace_back(a, d, b);
      }
    }
  return m;
}

namespace {
Vec3 strand_root(Index k, Index count, double spread, bool row) {
  if (count <= 1) return Vec3::Zero();
  if (row) return Vec3(-0.5 * spread + spread * k / (count - 1), 0.0, 0.0);
  const Index side = static_cast<Index>(std::ceil(std::sqrt(double(count))));
  const Index i = k % side, j = k / side;
  const double h = side > 1 ? spread / (side - 1) : 0.0;
  return Vec3(-0.5 * spread + i * h, 0.0, -0.5 * spread + j * h);
}
}  // namespace

PolylineSet curly_strands(Index count, Index vertices, double length, double spread, double coil_radius, double turns,
                          bool row) {
  if (count < 1 || vertices < 2) throw std::invalid_argument("strands need count >= 1 and vertices >= 2");
  check_count(static_cast<long long>(count) * vertices, "vertices",
              std::to_string(count) + " strands of " + std::to_string(vertices) + " vertices");
  PolylineSet s;
  for (Index k = 0; k < count; ++k) {
    const Vec3 root = strand_root(k, count, spread, row);
    std::vector<Index> line;
    for (Index i = 0; i < vertices; ++i) {
      const double u = double(i) / (vertices - 1);
      const double ang = 2.0 * std::numbers::pi * turns * u;
      Vec3 p = root + Vec3(coil_radius * (std::cos(ang) - 1.0), -length * u, coil_radius * std::sin(ang));
      line.push_back(static_cast<Index>(s.v.size()));
      s.v.push_back(p);
    }
    s.lines.push_back(std::move(line));
  }
  return s;
}

PolylineSet straight_strands(Index count, Index vertices, double length, double spread) {
  return curly_strands(count, vertices, length, spread, 0.0, 0.0);
}

Positions particle_block(Index nx, Index ny, Index nz, double spacing) {
  if (nx < 1 || ny < 1 || nz < 1) throw std::invalid_argument("particle block counts must be >= 1");
  check_count(static_cast<long long>(nx) * ny * nz, "particles",
              "particle counts [" + std::to_string(nx) + ", " + std::to_string(ny) + ", " + std::to_string(nz) + "]");
  Positions p;
  const Vec3 c = 0.5 * spacing * Vec3(nx - 1, ny - 1, nz - 1);
  for (Index k = 0; k < nz; ++k)
    for (Index j = 0; j < ny; ++j)
      for (Index i = 0; i < nx; ++i) p.push_back(spacing * Vec3(i, j, k) - c);
  return p;
}

TetMesh tet_box(const Vec3& size, const Vec3i& res) {
  if ((res.array() < 1).any()) throw std::invalid_argument("tet box resolution must be >= 1");
  if (!(size.array() > 0).all() || !size.allFinite())
    throw std::invalid_argument("tet box sizes must be finite and > 0");
  const std::string what = "tet_box resolution [" + std::to_string(res.x()) + ", " + std::to_string(res.y()) + ", " +
                           std::to_string(res.z()) + "]";
  check_count((res.x() + 1LL) * (res.y() + 1LL) * (res.z() + 1LL), "vertices", what);
  check_count(6LL * res.x() * res.y() * res.z(), "tets", what);
  TetMesh m;
  const Index nx = res.x() + 1, ny = res.y() + 1, nz = res.z() + 1;
  auto id = [&](Index i, Index j, Index k) { return (k * ny + j) * nx + i; };
  for (Index k = 0; k < nz; ++k)
    for (Index j = 0; j < ny; ++j)
      for (Index i = 0; i < nx; ++i)
        m.v.emplace_back(size.x() * (double(i) / res.x() - 0.5), size.y() * (double(j) / res.y() - 0.5),
                         size.z() * (double(k) / res.z() - 0.5));
  // Kuhn subdivision: 6 tets around the cell diagonal 0-7; conforming across cells.
  static constexpr int kTets[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7},
                                      {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};
  for (Index k = 0; k < res.z(); ++k)
    for (Index j = 0; j < res.y(); ++j)
      for (Index i = 0; i < res.x(); ++i) {
        Index c[8];
        for (int b = 0; b < 8; ++b) c[b] = id(i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1));
        for (const auto& t : kTets) {
          Vec4i tet(c[t[0]], c[t[1]], c[t[2]], c[t[3]]);
          const Vec3 &a = m.v[tet[0]], &b = m.v[tet[1]], &cc = m.v[tet[2]], &d = m.v[tet[3]];
          if ((b - a).cross(cc - a).dot(d - a) < 0) std::swap(tet[2], tet[3]);
          m.t.push_back(tet);
        }
      }
  return m;
}

TriMesh sphere(double radius, int subdivisions) {
  const double p = (1.0 + std::sqrt(5.0)) / 2.0;
  TriMesh m;
  m.v = {{-1, p, 0},  {1, p, 0},  {-1, -p, 0}, {1, -p, 0}, {0, -1, p},  {0, 1, p},
         {0, -1, -p}, {0, 1, -p}, {p, 0, -1},  {p, 0, 1},  {-p, 0, -1}, {-p, 0, 1}};
  m.f = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
         {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
         {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (auto& v : m.v) v.normalize();
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<Index, Index>, Index> mid;
    auto midpoint = [&](Index a, Index b) {
      auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      m.v.push_back((m.v[a] + m.v[b]).normalized());
      return mid[key] = static_cast<Index>(m.v.size()) - 1;
    };
    std::vector<Vec3i> f;
    for (const auto& t : m.f) {
      Index a = midpoint(t[0], t[1]), b = midpoint(t[1], t[2]), c = midpoint(t[2], t[0]);
      f.emplace_back(t[0], a, c);
      f.emplace_back(t[1], b, a);
      f.emplace_back(t[2], c, b);
      f.emplace_back(a, b, c);
    }
    m.f = std::move(f);
  }
  for (auto& v : m.v) v *= radius;
  return m;
}

TriMesh cylinder(double radius, double height, Index segments, bool capped) {
  if (segments < 3) throw std::invalid_argument("cylinder needs >= 3 segments");
  check_count(4LL * segments + 2, "faces", "cylinder of " + std::to_string(segments) + " segments");
  TriMesh m;
  for (Index k = 0; k < 2; ++k)
    for (Index i = 0; i < segments; ++i) {
      const double a = 2.0 * std::numbers::pi * i / segments;
      m.v.emplace_back(radius * std::cos(a), height * (k - 0.5), radius * std::sin(a));
    }
  for (Index i = 0; i < segments; ++i) {
    const Index j = (i + 1) % segments;
    // Outward: bottom ring i, j and top ring i+s, j+s.
    m.f.emplace_back(i, i + segments, j);
    m.f.emplace_back(j, i + segments, j + segments);
  }
  if (capped) {
    const Index bottom = static_cast<Index>(m.v.size());
    m.v.emplace_back(0, -0.5 * height, 0);
    const Index top = bottom + 1;
    m.v.emplace_back(0, 0.5 * height, 0);
    for (Index i = 0; i < segments; ++i) {
      const Index j = (i + 1) % segments;
      m.f.emplace_back(bottom, i, j);
      m.f.emplace_back(top, j + segments, i + segments);
    }
  }
  return m;
}

TriMesh box(const Vec3& size) {
  TriMesh m;
  const Vec3 h = 0.5 * size;
  for (int b = 0; b < 8; ++b)
    m.v.emplace_back((b & 1) ? h.x() : -h.x(), (b & 2) ? h.y() : -h.y(), (b & 4) ? h.z() : -h.z());
  // Faces (outward): -x, +x, -y, +y, -z, +z.
  m.f = {{0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}, {0, 1, 5}, {0, 5, 4},
         {2, 6, 7}, {2, 7, 3}, {0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}};
  return m;
}

TriMesh open_box(const Vec3& size) {
  TriMesh closed = box(size);
  TriMesh m;
  m.v = closed.v;
  for (size_t i = 0; i < closed.f.size(); ++i) {
    if (i == 6 || i == 7) continue;  // drop the lid (+y)
    const Vec3i& f = closed.f[i];
    m.f.emplace_back(f[0], f[2], f[1]);  // inward normals: the contents live inside
  }
  return m;
}

TriMesh plane(double size, Index res) { return grid(size, size, res, res); }

TetMesh tet_voxels(const std::vector<Vec3i>& cells, double h) {
  if (cells.empty()) throw std::invalid_argument("tet_voxels needs at least one cell");
  TetMesh m;
  std::map<std::array<Index, 3>, Index> corner_id;
  auto corner = [&](Index i, Index j, Index k) {
    auto [it, added] = corner_id.try_emplace({i, j, k}, static_cast<Index>(m.v.size()));
    if (added) m.v.emplace_back(h * i, h * j, h * k);
    return it->second;
  };
  static constexpr int kTets[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7},
                                      {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};
  std::map<std::array<Index, 3>, bool> seen;
  for (const auto& cell : cells) {
    if (!seen.try_emplace({cell.x(), cell.y(), cell.z()}, true).second) continue;  // duplicates are harmless
    Index c[8];
    for (int b = 0; b < 8; ++b) c[b] = corner(cell.x() + (b & 1), cell.y() + ((b >> 1) & 1), cell.z() + ((b >> 2) & 1));
    for (const auto& t : kTets) {
      Vec4i tet(c[t[0]], c[t[1]], c[t[2]], c[t[3]]);
      if ((m.v[tet[1]] - m.v[tet[0]]).cross(m.v[tet[2]] - m.v[tet[0]]).dot(m.v[tet[3]] - m.v[tet[0]]) < 0)
        std::swap(tet[2], tet[3]);
      m.t.push_back(tet);
    }
  }
  return m;
}

TetMesh octopus(double h, Index body, Index legs, Index leg_length) {
  if (body < 2 || legs < 0 || leg_length < 0)
    throw std::invalid_argument("octopus needs body >= 2, legs >= 0, leg_length >= 0");
  check_count(6LL * body * body * body + 12LL * legs * leg_length, "tets", "octopus body " + std::to_string(body));
  std::vector<Vec3i> cells;
  for (Index i = 0; i < body; ++i)
    for (Index j = 0; j < body; ++j)
      for (Index k = 0; k < body; ++k) cells.emplace_back(i, j, k);
  const double c = 0.5 * (body - 1);
  for (Index l = 0; l < legs; ++l) {
    const double a = 2.0 * std::numbers::pi * l / std::max<Index>(legs, 1);
    const double dx = std::cos(a), dz = std::sin(a);
    // Start under the body's rim in this direction, then alternate outward and downward steps
    // (face-adjacent cells, so the leg stays one connected solid).
    Vec3i cur(static_cast<Index>(std::lround(c + c * dx)), -1, static_cast<Index>(std::lround(c + c * dz)));
    double fx = cur.x(), fz = cur.z();
    cells.push_back(cur);
    for (Index s = 1; s < leg_length; ++s) {
      if (s % 2) {
        fx += 0.8 * dx;
        fz += 0.8 * dz;
        const Vec3i target(static_cast<Index>(std::lround(fx)), cur.y(), static_cast<Index>(std::lround(fz)));
        if (target.x() != cur.x()) cur.x() = target.x(), cells.push_back(cur);
        if (target.z() != cur.z()) cur.z() = target.z(), cells.push_back(cur);
      } else {
        cur.y() -= 1;
        cells.push_back(cur);
      }
    }
  }
  TetMesh m = tet_voxels(cells, h);
  Vec3 lo = m.v.front(), hi = m.v.front();
  for (const auto& p : m.v) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const Vec3 centre = 0.5 * (lo + hi);
  for (auto& p : m.v) p -= centre;
  return m;
}

TriMesh merge(const std::vector<TriMesh>& parts) {
  TriMesh m;
  for (const auto& p : parts) {
    const Index base = static_cast<Index>(m.v.size());
    m.v.insert(m.v.end(), p.v.begin(), p.v.end());
    for (const auto& f : p.f) m.f.emplace_back(f[0] + base, f[1] + base, f[2] + base);
  }
  return m;
}

TriMesh comb(double length, double width, double spine_height, Index teeth, double tooth_length, double tooth_width) {
  if (teeth < 1) throw std::invalid_argument("a comb needs at least one tooth");
  check_count(12LL * (teeth + 1LL), "faces", "comb of " + std::to_string(teeth) + " teeth");
  std::vector<TriMesh> parts;
  TriMesh spine = box(Vec3(length, spine_height, width));
  for (auto& v : spine.v) v.y() += 0.5 * spine_height;
  parts.push_back(spine);
  for (Index t = 0; t < teeth; ++t) {
    TriMesh tooth = box(Vec3(tooth_width, tooth_length, width));
    const double x = teeth == 1 ? 0.0 : -0.5 * (length - tooth_width) + (length - tooth_width) * t / (teeth - 1);
    for (auto& v : tooth.v) v += Vec3(x, -0.5 * tooth_length, 0.0);
    parts.push_back(tooth);
  }
  return merge(parts);
}

}  // namespace ccfr::gen
