#include "ccfr/geometry_exact/audit.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>

#include <Eigen/SVD>

#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry/aabb.hpp"
#include "ccfr/geometry/adjacency.hpp"
#include "ccfr/geometry/bvh.hpp"
#include "ccfr/geometry/distance.hpp"
#include "ccfr/geometry_exact/predicates.hpp"

namespace ccfr::exact {

namespace {

enum SubPair : std::uint64_t { kVF = 0, kEE = 1, kVE = 2, kVV = 3 };

std::uint64_t key(std::uint64_t type, Index a, Index b) {
  return (type << 62) | (static_cast<std::uint64_t>(a) << 31) | static_cast<std::uint64_t>(b);
}
std::uint64_t sym_key(std::uint64_t type, Index a, Index b) { return key(type, std::min(a, b), std::max(a, b)); }

bool contains(const std::vector<std::uint64_t>& sorted, std::uint64_t k) {
  return std::binary_search(sorted.begin(), sorted.end(), k);
}

bool face_has(const Vec3i& f, Index v) { return f[0] == v || f[1] == v || f[2] == v; }
bool edge_has(const Vec2i& e, Index v) { return e[0] == v || e[1] == v; }
bool faces_share(const Vec3i& f, const Vec3i& g) { return face_has(g, f[0]) || face_has(g, f[1]) || face_has(g, f[2]); }
bool edges_share(const Vec2i& e, const Vec2i& g) { return edge_has(g, e[0]) || edge_has(g, e[1]); }
bool edge_face_share(const Vec2i& e, const Vec3i& f) { return face_has(f, e[0]) || face_has(f, e[1]); }

// The double prefilter only decides which sub-pairs are "within range" (a report of the minimum
// distance); the close/not-close verdict is always the exact comparison. This slack keeps a
// sub-pair whose exact distance is just below xi from being dropped by double rounding.
constexpr double kRangeSlack = 1e-6;

void check_finite(const Topology& topo, const Positions& x, const char* what) {
  if (static_cast<Index>(x.size()) != topo.num_vertices())
    throw Error(std::string("audit: ") + what + " has " + std::to_string(x.size()) + " vertices, the topology has " +
                std::to_string(topo.num_vertices()));
  for (Index v = 0; v < static_cast<Index>(x.size()); ++v)
    if (!x[v].allFinite())
      throw Error(std::string("audit: ") + what + ": vertex " + std::to_string(v) + " (object '" +
                  topo.object_of_vertex(v).name + "') has a non-finite coordinate");
}

}  // namespace

const char* to_string(AuditExample::Kind kind) {
  switch (kind) {
    case AuditExample::Kind::triangle_triangle:
      return "triangle-triangle intersection";
    case AuditExample::Kind::segment_triangle:
      return "segment through triangle";
    case AuditExample::Kind::vertex_face:
      return "vertex-face";
    case AuditExample::Kind::edge_edge:
      return "edge-edge";
    case AuditExample::Kind::vertex_edge:
      return "vertex-edge";
    case AuditExample::Kind::vertex_vertex:
      return "vertex-vertex";
    case AuditExample::Kind::rigid_deformation:
      return "rigid deformation";
  }
  return "?";
}

std::string AuditExample::describe() const {
  static const char* names[][2] = {{"face", "face"}, {"edge", "face"},   {"vertex", "face"},
                                   {"edge", "edge"}, {"vertex", "edge"}, {"vertex", "vertex"}};
  const auto k = static_cast<int>(kind);
  std::ostringstream s;
  if (kind == Kind::rigid_deformation) {
    s << to_string(kind) << ": object '" << object << "' is no rigid transform of its reference shape: vertex " << a
      << " is " << distance << " from its best rigid fit";
    return s.str();
  }
  s << to_string(kind) << ": " << names[k][0] << ' ' << a << " - " << names[k][1] << ' ' << b;
  if (kind != Kind::triangle_triangle && kind != Kind::segment_triangle) s << " at distance " << distance;
  if (!object.empty()) s << " (objects '" << object << "')";
  return s.str();
}

PenetrationAudit::PenetrationAudit(Topology topology, const Positions& reference, AuditOptions options)
    : topo_(std::move(topology)), opt_(options) {
  if (!(opt_.offset > 0.0) || !std::isfinite(opt_.offset))
    throw Error("audit: the offset xi must be positive and finite (got " + std::to_string(opt_.offset) + ")");
  if (!(opt_.tolerance >= 0.0 && opt_.tolerance < 1.0))
    throw Error("audit: the tolerance must lie in [0, 1) (got " + std::to_string(opt_.tolerance) + ")");
  check_finite(topo_, reference, "the reference configuration");
  if (!opt_.object_roles.empty() && opt_.object_roles.size() != topo_.objects.size())
    throw Error("audit: " + std::to_string(opt_.object_roles.size()) + " object roles given, the topology has " +
                std::to_string(topo_.objects.size()) + " objects");
  if (std::any_of(opt_.object_roles.begin(), opt_.object_roles.end(),
                  [](std::uint8_t r) { return (r & kRigidObject) != 0; }))
    reference_ = reference;

  vertex_role_.assign(static_cast<size_t>(topo_.num_vertices()), 0);
  for (const Vec3i& f : topo_.faces)
    for (int k = 0; k < 3; ++k) vertex_role_[f[k]] = 1;
  for (const Vec2i& e : topo_.edges) vertex_role_[e[0]] = vertex_role_[e[1]] = 1;
  for (const ObjectInfo& o : topo_.objects)
    if (o.kind == ObjectKind::particles)
      for (Index v = o.vertex_begin; v < o.vertex_end; ++v) vertex_role_[v] = 2;
  strand_edge_.assign(static_cast<size_t>(topo_.num_edges()), 0);
  for (Index e = 0; e < topo_.num_edges(); ++e)
    strand_edge_[e] = topo_.objects[topo_.edge_object[e]].kind == ObjectKind::strand;

  std::vector<CloseKey> close;
  run(reference, true, &close, &excluded_tt_, &excluded_st_);
  for (auto* v : {&excluded_tt_, &excluded_st_}) {
    std::sort(v->begin(), v->end());
    v->erase(std::unique(v->begin(), v->end()), v->end());
  }
  std::sort(close.begin(), close.end(), [](const CloseKey& a, const CloseKey& b) { return a.key < b.key; });
  close.erase(
      std::unique(close.begin(), close.end(), [](const CloseKey& a, const CloseKey& b) { return a.key == b.key; }),
      close.end());

  // Every sub-pair of a primitive pair crossing in the reference is excluded, as in the simulation
  // (its closest points there give inverted normals).
  constexpr std::uint64_t kMask = (std::uint64_t{1} << 31) - 1;
  for (std::uint64_t k : excluded_tt_) {
    const Index f = static_cast<Index>((k >> 31) & kMask), g = static_cast<Index>(k & kMask);
    const Vec3i &fv = topo_.faces[f], &gv = topo_.faces[g];
    for (int a = 0; a < 3; ++a) {
      if (!face_has(gv, fv[a])) excluded_close_.push_back(key(kVF, fv[a], g));
      if (!face_has(fv, gv[a])) excluded_close_.push_back(key(kVF, gv[a], f));
      for (int b = 0; b < 3; ++b) {
        const Index e = topo_.face_edges[f][a], h = topo_.face_edges[g][b];
        if (!edges_share(topo_.edges[e], topo_.edges[h])) excluded_close_.push_back(sym_key(kEE, e, h));
      }
    }
  }
  for (std::uint64_t k : excluded_st_) {
    const Index e = static_cast<Index>((k >> 31) & kMask), f = static_cast<Index>(k & kMask);
    const Vec2i& ev = topo_.edges[e];
    const Vec3i& fv = topo_.faces[f];
    for (int a = 0; a < 2; ++a)
      if (!face_has(fv, ev[a])) excluded_close_.push_back(key(kVF, ev[a], f));
    for (int b = 0; b < 3; ++b) {
      const Index h = topo_.face_edges[f][b];
      if (!edges_share(ev, topo_.edges[h])) excluded_close_.push_back(sym_key(kEE, e, h));
    }
  }
  std::sort(excluded_close_.begin(), excluded_close_.end());
  excluded_close_.erase(std::unique(excluded_close_.begin(), excluded_close_.end()), excluded_close_.end());
  const std::vector<std::uint64_t> crossing = excluded_close_;

  // Close in the reference: adjacent sub-pairs are excluded, the others keep a reduced offset.
  TopologicalAdjacency adjacency;
  if (!close.empty()) {
    std::vector<std::uint8_t> sources(static_cast<size_t>(topo_.num_vertices()), 0);
    for (const CloseKey& c : close) {
      Index v[5];
      int n = 0;
      const int na = sub_pair_vertices(c.key, v, n);
      for (int i = 0; i < na; ++i) sources[v[i]] = 1;
    }
    adjacency = TopologicalAdjacency(topo_, reference, kAdjacencyRadiusInOffsets * opt_.offset, sources);
  }
  for (const CloseKey& c : close) {
    if (contains(crossing, c.key)) continue;
    Index v[5];
    int n = 0;
    const int na = sub_pair_vertices(c.key, v, n);
    if (adjacency.adjacent(std::span<const Index>(v, static_cast<size_t>(na)),
                           std::span<const Index>(v + na, static_cast<size_t>(n - na)))) {
      excluded_close_.push_back(c.key);
      ++adjacent_excluded_;
    } else {
      reduced_key_.push_back(c.key);  // ascending: close is sorted
      reduced_offset_.push_back((1.0 - kInitialOffsetMargin) * c.distance);
    }
  }
  std::sort(excluded_close_.begin(), excluded_close_.end());
}

Index PenetrationAudit::excluded_close_pairs() const { return adjacent_excluded_; }

int PenetrationAudit::sub_pair_vertices(std::uint64_t k, Index (&v)[5], int& n) const {
  constexpr std::uint64_t kMask = (std::uint64_t{1} << 31) - 1;
  const Index a = static_cast<Index>((k >> 31) & kMask), b = static_cast<Index>(k & kMask);
  switch (k >> 62) {
    case kVF: {
      const Vec3i& f = topo_.faces[b];
      v[0] = a, v[1] = f[0], v[2] = f[1], v[3] = f[2], n = 4;
      return 1;
    }
    case kEE: {
      const Vec2i &e = topo_.edges[a], &g = topo_.edges[b];
      v[0] = e[0], v[1] = e[1], v[2] = g[0], v[3] = g[1], n = 4;
      return 2;
    }
    case kVE: {
      const Vec2i& e = topo_.edges[b];
      v[0] = a, v[1] = e[0], v[2] = e[1], n = 3;
      return 1;
    }
    default:
      v[0] = a, v[1] = b, n = 2;
      return 1;
  }
}

double PenetrationAudit::key_distance_sq(std::uint64_t k, const Positions& x) const {
  Index v[5];
  int n = 0;
  sub_pair_vertices(k, v, n);
  switch (k >> 62) {
    case kVF:
      return point_triangle(x[v[0]], x[v[1]], x[v[2]], x[v[3]]).distance_sq;
    case kEE:
      return edge_edge(x[v[0]], x[v[1]], x[v[2]], x[v[3]]).distance_sq;
    case kVE:
      return point_edge(x[v[0]], x[v[1]], x[v[2]]).distance_sq;
    default:
      return (x[v[0]] - x[v[1]]).squaredNorm();
  }
}

double PenetrationAudit::pair_offset(std::uint64_t k) const {
  if (contains(excluded_close_, k)) return -1.0;
  const auto it = std::lower_bound(reduced_key_.begin(), reduced_key_.end(), k);
  return it != reduced_key_.end() && *it == k ? reduced_offset_[static_cast<size_t>(it - reduced_key_.begin())]
                                              : opt_.offset;
}

std::vector<std::uint8_t> PenetrationAudit::rigid_now(const Positions& x, FrameAudit* report) const {
  std::vector<std::uint8_t> rigid(topo_.objects.size(), 0);
  if (reference_.empty()) return rigid;
  for (size_t o = 0; o < topo_.objects.size(); ++o) {
    if (!(opt_.object_roles[o] & kRigidObject)) continue;
    const ObjectInfo& obj = topo_.objects[o];
    const Index n = obj.vertex_end - obj.vertex_begin;
    if (n == 0) continue;
    // The best rigid fit of the reference onto x (Kabsch: centroids, then the rotation from the
    // SVD of the cross-covariance, a reflection turned into a rotation).
    Vec3 cp = Vec3::Zero(), cq = Vec3::Zero();
    AABB box;
    for (Index v = obj.vertex_begin; v < obj.vertex_end; ++v) {
      cp += reference_[v];
      cq += x[v];
      box.expand(reference_[v]);
    }
    cp /= static_cast<double>(n);
    cq /= static_cast<double>(n);
    Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
    for (Index v = obj.vertex_begin; v < obj.vertex_end; ++v) h += (reference_[v] - cp) * (x[v] - cq).transpose();
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
    d(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;
    const Eigen::Matrix3d r = svd.matrixV() * d * svd.matrixU().transpose();
    double worst = 0.0;
    Index worst_v = obj.vertex_begin;
    for (Index v = obj.vertex_begin; v < obj.vertex_end; ++v) {
      const double dev = (r * (reference_[v] - cp) + cq - x[v]).norm();
      if (dev > worst) worst = dev, worst_v = v;
    }
    const double extent = (box.hi - box.lo).norm();
    if (worst <= opt_.rigid_tolerance * extent) {
      rigid[o] = 1;
    } else if (report) {
      ++report->rigid_deformations;
      if (report->examples.size() < static_cast<size_t>(std::max(opt_.max_examples, 0)))
        report->examples.push_back(
            AuditExample{AuditExample::Kind::rigid_deformation, worst_v, static_cast<Index>(o), worst, obj.name});
    }
  }
  return rigid;
}

FrameAudit PenetrationAudit::audit(const Positions& x) const {
  check_finite(topo_, x, "the configuration");
  return run(x, false, nullptr, nullptr, nullptr);
}

void PenetrationAudit::raise_offsets(const Positions& x) {
  check_finite(topo_, x, "the configuration");
  const double xi = opt_.offset;
  parallel_for(
      static_cast<Index>(reduced_key_.size()),
      [&](Index b, Index e) {
        for (Index i = b; i < e; ++i) {
          if (!(reduced_offset_[i] < xi)) continue;
          const double raised =
              std::min(xi, (1.0 - kInitialOffsetMargin) * std::sqrt(key_distance_sq(reduced_key_[i], x)));
          if (raised > reduced_offset_[i]) reduced_offset_[i] = raised;
        }
      },
      1024);
}

void PenetrationAudit::restore_reduced_offsets(std::span<const double> offsets) {
  if (offsets.size() != reduced_offset_.size())
    throw Error("audit state: " + std::to_string(offsets.size()) + " reduced offsets given, the audit has " +
                std::to_string(reduced_offset_.size()));
  for (size_t i = 0; i < offsets.size(); ++i)
    if (!std::isfinite(offsets[i]) || offsets[i] < reduced_offset_[i] || offsets[i] > opt_.offset)
      throw Error("audit state: reduced offset " + std::to_string(i) + " is outside its initial value and xi");
  reduced_offset_.assign(offsets.begin(), offsets.end());
}

FrameAudit PenetrationAudit::audit_next(const Positions& x) {
  FrameAudit r = audit(x);
  raise_offsets(x);
  return r;
}

namespace {

/// What one pass compares distances against (squared lengths, in the positions' units).
struct AuditRanges {
  bool reference_pass = false;
  double xi = 0.0;           ///< the offset
  double xi_range_sq = 0.0;  ///< xi² with the double prefilter's slack: close verdicts
  double range_sq = 0.0;     ///< the minimum-distance report's reach, squared, with the slack
  double limit_sq = 0.0;     ///< ((1 - tolerance) xi)²: closer is a close pair
  size_t max_examples = 0;
};

/// The object of element i: vertices [0, nv), edges [nv, nv + ne), faces [nv + ne, ...).
Index object_of(const Topology& topo, Index i) {
  const Index nv = topo.num_vertices(), ne = topo.num_edges();
  return i < nv ? topo.vertex_object[i] : i < nv + ne ? topo.edge_object[i - nv] : topo.face_object[i - nv - ne];
}

/// One box per element (ids as object_of), grown by `grow`; vertices of role 0 (tet interiors,
/// unused vertices: no primitive) get an empty box.
std::vector<AABB> element_boxes(const Topology& topo, const std::vector<std::uint8_t>& vertex_role, const Positions& x,
                                double grow) {
  const Index nv = topo.num_vertices(), ne = topo.num_edges(), nf = topo.num_faces();
  std::vector<AABB> boxes(static_cast<size_t>(nv + ne + nf));
  parallel_for(nv + ne + nf, [&](Index begin, Index end) {
    for (Index i = begin; i < end; ++i) {
      AABB b;
      if (i < nv) {
        if (vertex_role[i] == 0) continue;
        b = AABB::of(x[i]);
      } else if (i < nv + ne) {
        const Vec2i& e = topo.edges[i - nv];
        b = AABB::of(x[e[0]], x[e[1]]);
      } else {
        const Vec3i& f = topo.faces[i - nv - ne];
        b = AABB::of(x[f[0]], x[f[1]], x[f[2]]);
      }
      b.inflate(grow);
      boxes[i] = b;
    }
  });
  return boxes;
}

/// The element pairs whose boxes overlap, but for those inside one object with rigid[object] set:
/// a rigid pile of scanned meshes costs only its pairs between objects.
std::vector<std::pair<Index, Index>> candidate_pairs(const Topology& topo, const std::vector<AABB>& boxes,
                                                     const std::vector<std::uint8_t>& rigid) {
  Bvh bvh;
  bvh.build(boxes, 4);
  std::vector<std::pair<Index, Index>> pairs;
  std::vector<std::uint32_t> groups;
  if (std::find(rigid.begin(), rigid.end(), 1) != rigid.end()) {
    groups.assign(boxes.size(), 0);
    for (Index i = 0; i < static_cast<Index>(boxes.size()); ++i) {
      const Index o = object_of(topo, i);
      if (rigid[o]) groups[i] = static_cast<std::uint32_t>(o + 1);
    }
  }
  if (groups.empty())
    bvh.self_pairs(pairs);
  else
    bvh.self_pairs(pairs, {}, groups);
  return pairs;
}

}  // namespace

// One chunk of the candidate pairs, classified in pair order; the chunks' results are merged in
// chunk order so that the report is deterministic.
struct PenetrationAudit::Scan {
  Scan(const PenetrationAudit& audit, const Positions& x, const AuditRanges& ranges,
       const std::vector<std::uint8_t>& rigid)
      : audit_(audit), x_(x), ranges_(ranges), rigid_(rigid) {}

  FrameAudit result;
  std::vector<CloseKey> close;
  std::vector<std::uint64_t> tt, st;

  /// Tests elements i < j (so i's element type comes first: V < E < F) and records the verdict.
  void classify(Index i, Index j) {
    const Topology& topo = audit_.topo_;
    const Index nv = topo.num_vertices(), ne = topo.num_edges();
    const Positions& x = x_;
    if (!audit_.opt_.object_roles.empty() && !ranges_.reference_pass) {
      const Index oi = object_of(topo, i), oj = object_of(topo, j);
      if (oi == oj && rigid_[oi]) return;  // not enumerated by the BVH; kept for clarity
      scene_ = (audit_.opt_.object_roles[oi] & kScriptedObject) && (audit_.opt_.object_roles[oj] & kScriptedObject);
      scene_a_ = oi, scene_b_ = oj;
    }
    const std::vector<std::uint8_t>& role = audit_.vertex_role_;
    if (j < nv) {
      // vertex-vertex: only between particles (meshes and strands: covered by VF / EE)
      if (role[i] != 2 || role[j] != 2) return;
      distance_pair(sym_key(kVV, i, j), (x[i] - x[j]).squaredNorm(), AuditExample::Kind::vertex_vertex, i, j,
                    [&](double t) { return compare_point_point_distance_sq(x[i], x[j], t); });
    } else if (i < nv && j < nv + ne) {
      const Index e = j - nv;
      const Vec2i& ev = topo.edges[e];
      if (role[i] != 2 || edge_has(ev, i)) return;
      const Vec3 &a = x[ev[0]], &b = x[ev[1]];
      distance_pair(key(kVE, i, e), point_edge(x[i], a, b).distance_sq, AuditExample::Kind::vertex_edge, i, e,
                    [&](double t) { return compare_point_edge_distance_sq(x[i], a, b, t); });
    } else if (i < nv) {
      const Index f = j - nv - ne;
      const Vec3i& fv = topo.faces[f];
      if (face_has(fv, i)) return;
      const Vec3 &a = x[fv[0]], &b = x[fv[1]], &cc = x[fv[2]];
      distance_pair(key(kVF, i, f), point_triangle(x[i], a, b, cc).distance_sq, AuditExample::Kind::vertex_face, i, f,
                    [&](double t) { return compare_point_triangle_distance_sq(x[i], a, b, cc, t); });
    } else if (j < nv + ne) {
      const Index e = i - nv, g = j - nv;
      const Vec2i &ev = topo.edges[e], &gv = topo.edges[g];
      if (edges_share(ev, gv)) return;
      const Vec3 &a0 = x[ev[0]], &a1 = x[ev[1]], &b0 = x[gv[0]], &b1 = x[gv[1]];
      distance_pair(sym_key(kEE, e, g), edge_edge(a0, a1, b0, b1).distance_sq, AuditExample::Kind::edge_edge, e, g,
                    [&](double t) { return compare_edge_edge_distance_sq(a0, a1, b0, b1, t); });
    } else if (i < nv + ne) {
      segment_triangle(i - nv, j - nv - ne);
    } else {
      triangle_triangle(i - nv - ne, j - nv - ne);
    }
  }

 private:
  void example(AuditExample::Kind kind, Index a, Index b, double d) {
    auto& list = scene_ ? result.scene_examples : result.examples;
    if (list.size() >= ranges_.max_examples) return;
    list.push_back(AuditExample{kind, a, b, d, {}});
    if (scene_)
      list.back().object = audit_.topo_.objects[scene_a_].name + "' and '" + audit_.topo_.objects[scene_b_].name;
  }
  void count(Index& counter) { ++(scene_ ? result.scene_pairs : counter); }

  /// A distance sub-pair: range filter in double, exclusions, then the exact verdict.
  template <class ExactCompare>
  void distance_pair(std::uint64_t k, double d2, AuditExample::Kind kind, Index a, Index b, ExactCompare&& exact_cmp) {
    const AuditRanges& rg = ranges_;
    if (!(d2 < (rg.reference_pass ? rg.xi_range_sq : rg.range_sq))) return;
    if (rg.reference_pass) {
      // The same exact comparison as the verdict, so the reference itself always audits clean.
      if (d2 < rg.xi_range_sq && exact_cmp(rg.xi * rg.xi) < 0) close.push_back({k, std::sqrt(d2)});
      return;
    }
    if (contains(audit_.excluded_close_, k)) return;
    const double d = std::sqrt(d2);
    if (!scene_) {  // the margin the method kept, not the scene's
      ++result.checked_pairs;
      result.min_distance = std::min(result.min_distance, d);
    }
    // A pair that started closer than xi is checked against its own (reduced) offset.
    double pair_limit_sq = rg.limit_sq, pair_range_sq = rg.xi_range_sq;
    const std::vector<std::uint64_t>& reduced = audit_.reduced_key_;
    if (!reduced.empty()) {
      const auto it = std::lower_bound(reduced.begin(), reduced.end(), k);
      if (it != reduced.end() && *it == k) {
        const double off = audit_.reduced_offset_[static_cast<size_t>(it - reduced.begin())];
        const double tol = audit_.opt_.tolerance;
        pair_limit_sq = (1.0 - tol) * off * (1.0 - tol) * off;
        pair_range_sq = off * off * (1.0 + kRangeSlack);
      }
    }
    if (d2 < pair_range_sq && exact_cmp(pair_limit_sq) < 0) {
      count(result.close_pairs);
      example(kind, a, b, d);
    }
  }

  /// A strand segment e through triangle f; face edges are covered by triangle-triangle tests.
  void segment_triangle(Index e, Index f) {
    if (!audit_.strand_edge_[e]) return;
    const Vec2i& ev = audit_.topo_.edges[e];
    const Vec3i& fv = audit_.topo_.faces[f];
    if (edge_face_share(ev, fv)) return;
    if (!segment_triangle_intersect(x_[ev[0]], x_[ev[1]], x_[fv[0]], x_[fv[1]], x_[fv[2]])) return;
    crossing(key(0, e, f), st, audit_.excluded_st_, result.segment_crossings, AuditExample::Kind::segment_triangle, e,
             f);
  }

  void triangle_triangle(Index f, Index g) {
    const Vec3i &fv = audit_.topo_.faces[f], &gv = audit_.topo_.faces[g];
    if (faces_share(fv, gv)) return;  // do_intersect is slowest exactly on these
    if (!triangles_intersect(x_[fv[0]], x_[fv[1]], x_[fv[2]], x_[gv[0]], x_[gv[1]], x_[gv[2]])) return;
    crossing(key(0, f, g), tt, audit_.excluded_tt_, result.triangle_intersections,
             AuditExample::Kind::triangle_triangle, f, g);
  }

  /// Elements a and b cross (key k): the reference pass records the key, a later pass counts
  /// the crossing unless the reference excluded it.
  void crossing(std::uint64_t k, std::vector<std::uint64_t>& reference_keys, const std::vector<std::uint64_t>& excluded,
                Index& counter, AuditExample::Kind kind, Index a, Index b) {
    if (ranges_.reference_pass) {
      reference_keys.push_back(k);
    } else if (!contains(excluded, k)) {
      count(counter);
      example(kind, a, b, 0.0);
    }
  }

  const PenetrationAudit& audit_;
  const Positions& x_;
  const AuditRanges& ranges_;
  const std::vector<std::uint8_t>& rigid_;
  bool scene_ = false;  ///< the pair being tested joins two scripted objects
  Index scene_a_ = 0, scene_b_ = 0;
};

FrameAudit PenetrationAudit::run(const Positions& x, bool reference_pass, std::vector<CloseKey>* close_keys,
                                 std::vector<std::uint64_t>* tt_keys, std::vector<std::uint64_t>* st_keys) const {
  AuditRanges rg;
  rg.reference_pass = reference_pass;
  rg.xi = opt_.offset;
  const double xi = rg.xi;
  // Close verdicts need candidates within xi only; the minimum-distance report looks further
  // (report_range xi) so that a clean run shows how much margin it kept.
  rg.xi_range_sq = xi * xi * (1.0 + kRangeSlack);
  const double reach = (reference_pass ? 1.0 : std::max(opt_.report_range, 1.0)) * xi;
  rg.range_sq = reach * reach * (1.0 + kRangeSlack);
  const double limit = (1.0 - opt_.tolerance) * xi;
  rg.limit_sq = limit * limit;
  rg.max_examples = static_cast<size_t>(std::max(opt_.max_examples, 0));
  // Grown by half the reach, every pair of primitives within it has overlapping boxes.
  const std::vector<AABB> boxes = element_boxes(topo_, vertex_role_, x, 0.5 * reach * (1.0 + kRangeSlack));
  // Rigid objects that moved rigidly: their pairs with themselves are skipped (unchanged but for
  // round-off since the reference); scripted objects: their pairs with each other are a scene error.
  FrameAudit rigid_report;
  const std::vector<std::uint8_t> rigid =
      reference_pass ? std::vector<std::uint8_t>(topo_.objects.size(), 0) : rigid_now(x, &rigid_report);
  const std::vector<std::pair<Index, Index>> pairs = candidate_pairs(topo_, boxes, rigid);

  const Index num_pairs = static_cast<Index>(pairs.size());
  const Index chunks = default_chunk_count(std::max<Index>(num_pairs, 1));
  std::vector<Scan> scans;
  scans.reserve(static_cast<size_t>(chunks));
  for (Index c = 0; c < chunks; ++c) scans.emplace_back(*this, x, rg, rigid);
  parallel_chunks(num_pairs, chunks, [&](Index c, Index begin, Index end) {
    for (Index p = begin; p < end; ++p) scans[c].classify(pairs[p].first, pairs[p].second);
  });

  FrameAudit out;
  out.rigid_deformations = rigid_report.rigid_deformations;
  out.examples = std::move(rigid_report.examples);
  for (Scan& sc : scans) {
    const FrameAudit& r = sc.result;
    out.triangle_intersections += r.triangle_intersections;
    out.segment_crossings += r.segment_crossings;
    out.close_pairs += r.close_pairs;
    out.checked_pairs += r.checked_pairs;
    out.scene_pairs += r.scene_pairs;
    for (const AuditExample& ex : r.scene_examples)
      if (out.scene_examples.size() < rg.max_examples) out.scene_examples.push_back(ex);
    out.min_distance = std::min(out.min_distance, r.min_distance);
    for (const AuditExample& ex : r.examples)
      if (out.examples.size() < rg.max_examples) out.examples.push_back(ex);
    if (reference_pass) {
      close_keys->insert(close_keys->end(), sc.close.begin(), sc.close.end());
      tt_keys->insert(tt_keys->end(), sc.tt.begin(), sc.tt.end());
      st_keys->insert(st_keys->end(), sc.st.begin(), sc.st.end());
    }
  }
  return out;
}

}  // namespace ccfr::exact
