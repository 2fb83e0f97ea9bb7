#include "memory.hpp"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <unordered_map>

#include "ccfr/core/process.hpp"
#include "ccfr/io/user_file.hpp"

namespace ccfr::io::scene {

// The memory model (io::memory_model; fitted and checked in docs/performance.md, "A memory
// estimate that tells the truth"). Peak RSS is the process base, about 1 KB per element, and
// about 170-270 bytes per half-space of the densest pass; the half-spaces are what the
// contact units predict. A movable vertex within reach D = 2r + ξ + δ of a surface of mean edge
// h_j holds about 20 ((h_i + h_j) / 2 + D)² / h_j² half-spaces (one per sub-pair with a primitive
// of that surface in reach), so each contact term counts vertices times that factor:
// self-contact of a sheet, a tet boundary or a strand; contact of a deformable with another
// object over the smaller of the two areas (a sheet has two sides: at most two such layers);
// and a rigid body's patch on another body, a cap of area 2π D ρ_eff (ρ_eff = ρ_i ρ_j / (ρ_i +
// ρ_j), ρ = 3 volume / area) where its surface meets its finest partner.
using namespace memory_model;

/// What the elements of one object (or of several: the sum is linear) add to the estimate.
double object_bytes(const Counts& c) {
  return kBytesPerVertex * (c.v - c.bv) + kBytesPerFace * (c.f - c.bf) + kBytesPerTet * c.t + kBytesPerSegment * c.e +
         kBytesPerBodyVertex * c.bv + kBytesPerBodyFace * c.bf + kBytesPerDrivenUnit * c.driven +
         kBytesPerStrandSelfUnit * c.strand + kBytesPerFineUnit * c.fine + kBytesPerGrainUnit * c.grains +
         kBytesPerCrossUnit * c.cross + kBytesPerPatchUnit * c.patch;
}

double estimate_bytes(const Counts& c) { return kBaseBytes + object_bytes(c); }

std::string count_str(double n) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.0f", n);
  return buf;
}

/// Memory the system can give this process without swapping: MemAvailable of /proc/meminfo, else
/// the free physical pages; 0 when unknown (then no limit is applied).
double available_memory_bytes() {
  std::ifstream mi("/proc/meminfo");
  std::string key;
  double kb = 0;
  std::string unit;
  while (mi >> key >> kb) {
    std::getline(mi, unit);
    if (key == "MemAvailable:") return kb * 1024.0;
  }
  const long pages = ::sysconf(_SC_AVPHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  return pages > 0 && page > 0 ? double(pages) * double(page) : 0.0;
}

/// "12.3 GB", or "45 MB" below 1 GB (a small scene's estimate would otherwise read 0.0 GB).
std::string gigabytes(double b) {
  char buf[32];
  if (b >= 1e9)
    std::snprintf(buf, sizeof buf, "%.1f GB", b / 1e9);
  else
    std::snprintf(buf, sizeof buf, "%.0f MB", b / 1e6);
  return buf;
}

namespace {

/// Sum over the points `who` (all of `x` when empty) of how many others of them lie within
/// `reach` and pass `accept(a, b)` (each pair counted from both sides), by hashing them into
/// cells of that size. Counting stops once it passes `stop_at` (what the memory limit allows:
/// such a scene is refused anyway), so that a million points packed far below the reach cannot
/// stall the loader.
template <class Accept>
double pairs_within(const Positions& x, std::vector<Index> who, double reach, double stop_at, Accept accept) {
  if (who.empty())
    for (size_t a = 0; a < x.size(); ++a) who.push_back(static_cast<Index>(a));
  if (who.size() < 2 || !(reach > 0)) return 0;
  std::unordered_map<std::uint64_t, std::vector<Index>> cells;
  auto key = [](std::int64_t i, std::int64_t j, std::int64_t k) {
    return (std::uint64_t(i & 0x1fffff) << 42) | (std::uint64_t(j & 0x1fffff) << 21) | std::uint64_t(k & 0x1fffff);
  };
  // The key wraps the cell indices into 21 bits each, which only merges far cells into one
  // bucket (their points fail the distance test), never misses a neighbour.
  auto index = [reach](double v) {
    return std::int64_t(std::clamp(std::floor(v / reach), -4.0e18, 4.0e18));  // a tiny reach must not overflow
  };
  auto cell = [&](const Vec3& p) -> std::array<std::int64_t, 3> { return {index(p.x()), index(p.y()), index(p.z())}; };
  for (const Index a : who) {
    const auto c = cell(x[a]);
    cells[key(c[0], c[1], c[2])].push_back(a);
  }
  double n = 0;
  const double r2 = reach * reach;
  for (const Index a : who) {
    const auto c = cell(x[a]);
    for (int di = -1; di <= 1; ++di)
      for (int dj = -1; dj <= 1; ++dj)
        for (int dk = -1; dk <= 1; ++dk) {
          const auto it = cells.find(key(c[0] + di, c[1] + dj, c[2] + dk));
          if (it == cells.end()) continue;
          for (const Index b : it->second)
            if (b != a && (x[b] - x[a]).squaredNorm() <= r2 && accept(a, b)) n += 1;
        }
    if (n > stop_at) return n;
  }
  return n;
}

/// A block of particles pairs with itself from the first frame, and a pile packs no looser.
double neighbours_within(const Positions& x, double reach, double stop_at) {
  return pairs_within(x, {}, reach, stop_at, [](Index, Index) { return true; });
}

/// Vertices of a surface within one disc of radius D: π D² over the area per vertex, √3 h² / 2.
constexpr double kVerticesPerFineUnit = 2 * std::numbers::pi / std::numbers::sqrt3;

/// Fine units of a surface's thin parts: per vertex, the vertices within `reach` that face it
/// (area-weighted normals more than 90° apart), over the vertices of one fine unit. A closed scan
/// pairs across its fingers and ears, and a folded sheet across its fold, at rest; the flat
/// neighbourhood that the fine term counts has them all on one side.
double facing_units(const RawGeometry& g, const std::vector<Vec3i>& faces, double reach, double stop_at) {
  std::vector<Vec3> normal(g.v.size(), Vec3::Zero());
  for (const auto& f : faces) {
    const Vec3 n = (g.v[f[1]] - g.v[f[0]]).cross(g.v[f[2]] - g.v[f[0]]);
    for (int k = 0; k < 3; ++k) normal[f[k]] += n;
  }
  std::vector<Index> on;
  for (size_t a = 0; a < g.v.size(); ++a)
    if (normal[a].squaredNorm() > 0) on.push_back(static_cast<Index>(a));
  const double pairs =
      pairs_within(g.v, std::move(on), reach, stop_at, [&](Index a, Index b) { return normal[a].dot(normal[b]) < 0; });
  return pairs / kVerticesPerFineUnit;
}

/// 3 V / A of a closed triangle surface (every edge in exactly two faces): the radius of a
/// sphere, 1.5 times a long tube's. 0 when the surface is open (it can be touched all over).
double body_radius(const RawGeometry& g) {
  std::map<std::pair<Index, Index>, int> uses;
  double area = 0, six_volume = 0;
  for (const auto& f : g.faces) {
    const Vec3 &a = g.v[f[0]], &b = g.v[f[1]], &c = g.v[f[2]];
    area += 0.5 * (b - a).cross(c - a).norm();
    six_volume += a.dot(b.cross(c));
    for (int k = 0; k < 3; ++k) ++uses[std::minmax(f[k], f[(k + 1) % 3])];
  }
  for (const auto& [e, n] : uses)
    if (n != 2) return 0.0;
  const double r = 3.0 * std::abs(six_volume / 6.0) / area;
  return std::isfinite(r) && r > 0 ? r : 0.0;
}

/// A sheet's two sides, one layer each; fewer when D < ξ cannot hold them.
/// More sheets than any stack within reach holds (layers_within_reach's bound is then D / ξ).
constexpr double kUnboundedSheets = 1e9;

double two_sides(double reach, double offset) { return std::min(2.0, std::max(1.0, 2.0 * reach / offset)); }

/// How many partner layers (in units of the nearest one) a sheet of mean edge h can hold within
/// reach D in a stack of sheets, layers being kept at least ξ apart: on each side the k-th sits
/// at k ξ, k = 1 .. floor(D / ξ), and holds the primitives within a disc of radius √(D² − (k
/// ξ)²), about (h + √(D² − (k ξ)²))² / h² of them. A landed pile of cloths packs 2-3 per side
/// (docs/performance.md, the 50 layers); one per side when D < 2ξ, and never more per side than
/// there are other sheets. Other kinds keep two_sides: they do not stack in layers.
double layers_within_reach(double h, double reach, double offset, double other_sheets) {
  if (!(reach >= 2 * offset) || other_sheets < 2) return two_sides(reach, offset);
  const auto within = [&](double k) {
    const double z = k * offset;
    return std::pow(h + std::sqrt(std::max(0.0, reach * reach - z * z)), 2);
  };
  const double n = std::min(std::floor(reach / offset), other_sheets);
  double sum = 0;
  for (double k = 1; k <= n; ++k) sum += within(k);
  return 2 * sum / within(1);
}

}  // namespace

/// The detection reach D = 2r + ξ + δ: how far apart two primitives can be and still pair.
double MemoryBudget::reach(const SimulationParams& p) {
  return 2 * p.contact.radius + p.contact.offset + p.contact.repulsion_range;
}

/// True if a pin group of `pins` (resolved) is moved by a script: such a sheet can be wound
/// onto itself (the twisting cloth becomes a rope), so its self-contact is charged as driven.
bool MemoryBudget::driven_by_pins(const YAML::Node& pins) {
  if (!pins || !pins.IsSequence()) return false;
  for (const auto& pn : pins)
    if (pn["motion"] && read_motion(pn["motion"]).moves()) return true;
  return false;
}

/// Element counts of generated or loaded geometry, with its collision surface (area, mean edge
/// h) and its self-contact units for reach D (io::memory_model).
Counts MemoryBudget::counts(const RawGeometry& g, ObjectKind kind, double reach, bool driven, double grain_cap) {
  Counts c{double(g.v.size()), double(g.faces.size()), double(g.tets.size()), 0};
  c.sv = c.v;
  for (const auto& l : g.lines) c.e += double(l.size()) - 1;
  // A tet solid collides through its boundary only: its surface faces and their edges set the
  // contact terms (a tetgen fill of a scanned surface has tets far coarser than the surface).
  const std::vector<Vec3i> boundary = kind == ObjectKind::tet_solid ? tet_boundary(g.tets) : std::vector<Vec3i>{};
  if (kind == ObjectKind::tet_solid) {
    c.f = double(boundary.size());
    std::vector<char> on(g.v.size(), 0);
    for (const auto& f : boundary) on[f[0]] = on[f[1]] = on[f[2]] = 1;
    c.sv = double(std::count(on.begin(), on.end(), 1));
  }
  double sum = 0, n = 0;
  // Per vertex too: a scanned or tetgen surface mixes edges of 1 and 10 mm, and (1 + D / h)² is
  // convex in 1 / h, so its fine patches crowd far more than the mean edge says.
  std::vector<double> vsum(g.v.size(), 0.0), vn(g.v.size(), 0.0);
  auto edge = [&](Index a, Index b) {
    const double l = (g.v[a] - g.v[b]).norm();
    sum += l, n += 1, vsum[a] += l, vsum[b] += l, vn[a] += 1, vn[b] += 1;
  };
  for (const auto& f : kind == ObjectKind::tet_solid ? boundary : g.faces) {
    edge(f[0], f[1]), edge(f[1], f[2]), edge(f[2], f[0]);
    c.area += 0.5 * (g.v[f[1]] - g.v[f[0]]).cross(g.v[f[2]] - g.v[f[0]]).norm();
  }
  for (const auto& l : g.lines)
    for (size_t k = 1; k < l.size(); ++k) edge(l[k - 1], l[k]);
  if (n > 0 && sum > 0) c.h = sum / n;
  if (kind == ObjectKind::strand) c.area = c.sv * c.h * c.h;
  // Self-contact, per vertex that collides with h_v its mean edge: a surface pairs with its own
  // flat neighbourhood where it is finer than D, (D / h_v)² (fine); one wound by scripted pins
  // also with the layers around it, (1 + D / h_v)² (driven); strands with their neighbours along
  // a bundle, 1 + D / h_v.
  // Each term is capped by the object's own primitives (its colliding vertices, edges and faces):
  // a vertex pairs with at most every one of them, however short its edges (a 7 nm tetgen edge
  // made q² ~ 1e12). `n` counts each edge once per face or segment holding it: at least once.
  const double primitives = std::max(1.0, c.sv + n + c.f);
  if (c.h > 0 && !is_body(kind))
    for (size_t k = 0; k < g.v.size(); ++k) {
      if (vn[k] == 0 || vsum[k] <= 0) continue;
      const double q = reach * vn[k] / vsum[k];
      if (kind == ObjectKind::strand) {
        c.strand += std::min(1 + q, primitives);
      } else {
        c.fine += std::min(q * q, primitives);
        if (driven) c.driven += std::min((1 + q) * (1 + q), primitives);
      }
    }
  if (c.h > 0 && !is_body(kind) && kind != ObjectKind::strand)
    c.fine += facing_units(g, kind == ObjectKind::tet_solid ? boundary : g.faces, reach, grain_cap);
  if (kind == ObjectKind::particles) c.grains = neighbours_within(g.v, reach, grain_cap);
  if (is_body(kind)) c.rho = body_radius(g);
  return as_kind(c, kind);
}

/// Fails when `add` (object `name`) does not fit 32-bit indices or the scene would need more
/// memory than the limit: max_memory if set, else what the machine has available.
void MemoryBudget::check_size(const Counts& before, const Counts& add, const std::string& spath,
                              const std::string& name, ObjectKind kind) const {
  Counts all = before;
  all += add;
  constexpr double kMax = std::numeric_limits<Index>::max();
  const std::pair<double, const char*> counts[] = {
      {add.v, "vertices"}, {add.f, "faces"}, {add.t, "tets"}, {add.e, "segments"}};
  for (const auto& [n, what] : counts)
    if (n > kMax)
      in_.ctx.fail(
          spath, in_.in_node(spath),
          "makes " + count_str(n) + " " + what + ", more than the " + count_str(kMax) + " that 32-bit indices address");
  if (all.v > kMax)
    in_.ctx.fail(spath, in_.in_node(spath),
                 "the scene would have " + count_str(all.v) + " vertices, more than the " + count_str(kMax) +
                     " that 32-bit indices address");
  std::vector<ObjectCost> costs = costs_;
  costs.push_back({name, kind, add});
  refuse_if_too_large(all, costs, spath);
}

/// Charges contact between objects (io::memory_model), once every object is known: each
/// movable object (not an obstacle) for the half-spaces its vertices hold. With a deformable on
/// either side, a vertex of i touches j over at most the smaller area, min(1, A_j / A_i) of i,
/// with about F_ij = ((h_i + h_j) / 2 + D)² / h_j² half-spaces (1 for particles, which have no
/// edges), summing at most two layers (a sheet's two sides), or, for a sheet among other sheets,
/// the layers a stack can pack within D (layers_within_reach). Two
/// bodies meet on a patch: a rigid body is charged its largest cap 2π D ρ_eff with another
/// body, times F per vertex area (A / h_i²), an open surface counting as a plane.
void MemoryBudget::charge_contact(Counts& total, double reach, double offset) {
  const auto is_sheet = [](ObjectKind k) { return k == ObjectKind::cloth || k == ObjectKind::shell; };
  const double sheets =
      static_cast<double>(std::count_if(costs_.begin(), costs_.end(), [&](const auto& c) { return is_sheet(c.kind); }));
  for (size_t i = 0; i < costs_.size(); ++i) {
    Counts& ci = costs_[i].counts;
    const ObjectKind ki = costs_[i].kind;
    if (ki == ObjectKind::obstacle) continue;  // its vertices never move: no half-space of its own
    const double layers =
        is_sheet(ki) ? layers_within_reach(ci.h, reach, offset, sheets - 1) : two_sides(reach, offset);
    // A sheet moved by scripted pins is bunched against what holds it back (a napkin pulled
    // through a ring: 58 MB estimated, 87 MB peak): the layers a bunch packs within D per side,
    // as a stack does, each meet the partner, so its share of the sheet grows by that many.
    const double bunch = is_sheet(ki) && ci.driven > 0
                             ? std::max(1.0, layers_within_reach(ci.h, reach, offset, kUnboundedSheets) / 2)
                             : 1.0;
    double cross = 0, cover = 0, patch = 0;
    for (size_t j = 0; j < costs_.size(); ++j) {
      const Counts& cj = costs_[j].counts;
      if (j == i || cj.v <= 0) continue;
      const double f = cj.h > 0 ? std::pow((ci.h + cj.h) / 2 + reach, 2) / (cj.h * cj.h) : 1.0;
      if (is_body(ki) && is_body(costs_[j].kind)) {
        const double inf = std::numeric_limits<double>::infinity();
        const double ri = ci.rho > 0 ? ci.rho : inf, rj = cj.rho > 0 ? cj.rho : inf;
        const double eff = std::isinf(ri) ? rj : std::isinf(rj) ? ri : ri * rj / (ri + rj);
        const double cap = std::min({2 * std::numbers::pi * reach * eff, ci.area, cj.area});
        if (ci.h > 0) patch = std::max(patch, cap / (ci.h * ci.h) * f);
      } else {
        const double share = ci.area > 0 && cj.area > 0 ? std::min(1.0, bunch * cj.area / ci.area) : 1.0;
        cross += share * f, cover += share;
      }
    }
    if (cover > layers) cross *= layers / cover;
    ci.cross = ci.sv * cross, ci.patch = patch;
    total.cross += ci.cross, total.patch += ci.patch;
  }
}

void MemoryBudget::refuse_if_too_large(const Counts& all, const std::vector<ObjectCost>& costs,
                                       const std::string& spath) const {
  const double need = estimate_bytes(all), have = limit();
  if (have > 0 && need > have) {
    in_.ctx.fail(spath, in_.in_node(spath),
                 "the scene would need about " + gigabytes(need) + " of memory (" + cost_list(costs) + "; " +
                     count_str(all.v) + " vertices" + (all.f > 0 ? ", " + count_str(all.f) + " faces" : "") +
                     (all.t > 0 ? ", " + count_str(all.t) + " tets" : "") +
                     (all.e > 0 ? ", " + count_str(all.e) + " strand segments" : "") + "), more than the " +
                     gigabytes(have) + (max_memory_gb_ > 0 ? " of max_memory" : " available (MemAvailable)") +
                     ". Contact memory grows with the half-spaces of the densest pass, about (1 + D / h)^2 per "
                     "vertex in contact with a surface of mean edge h, D = 2 radius + offset + repulsion_range: "
                     "coarsen the finest meshes, or reduce the contact offset and radius; or, "
                     "if the machine has the memory, raise the limit with max_memory (GB) or `ccfr run "
                     "--max-memory GB` (docs/choosing-parameters.md)");
  }
}

/// The bytes a scene may be estimated to need: max_memory (GB) if set, else what the machine has
/// available; CCFR_MEMORY_LIMIT_MB caps either (the fuzz targets run under a small RSS limit).
double MemoryBudget::limit() const {
  if (available_ < 0) {
    available_ = max_memory_gb_ > 0 ? max_memory_gb_ * 1e9 : available_memory_bytes();
    if (const char* cap = std::getenv("CCFR_MEMORY_LIMIT_MB")) {
      const double mb = std::atof(cap);
      if (mb > 0) available_ = available_ > 0 ? std::min(available_, mb * 1e6) : mb * 1e6;
    }
  }
  return available_;
}

/// The estimate the scene was admitted with, per object (after build()).
MemoryEstimate MemoryBudget::estimate() const {
  MemoryEstimate m;
  Counts total;
  for (const ObjectCost& c : costs_) {
    total += c.counts;
    ObjectMemory o;
    o.name = c.name;
    o.vertices = c.counts.v, o.faces = c.counts.f, o.tets = c.counts.t, o.segments = c.counts.e;
    o.mean_edge = c.counts.h, o.area = c.counts.area, o.body_radius = c.counts.rho;
    o.fine_contact = c.counts.fine, o.driven_contact = c.counts.driven, o.strand_contact = c.counts.strand;
    o.grain_contact = c.counts.grains;
    o.cross_contact = c.counts.cross, o.patch_contact = c.counts.patch;
    o.bytes = object_bytes(c.counts);
    m.objects.push_back(std::move(o));
  }
  m.total_bytes = estimate_bytes(total);
  const double have = limit();
  m.limit_is_max_memory = max_memory_gb_ > 0;
  m.limit_bytes = have > 0 ? have + (m.limit_is_max_memory ? 0.0 : resident_bytes()) : 0.0;
  return m;
}

std::string MemoryBudget::cost_list(const std::vector<ObjectCost>& costs) {
  std::string out;
  for (const ObjectCost& c : costs)
    out += (out.empty() ? "" : ", ") + ("'" + printable(c.name) + "' (" + std::string(to_string(c.kind)) + ", " +
                                        count_str(c.counts.v) + " vertices) " + gigabytes(object_bytes(c.counts)));
  return out;
}

}  // namespace ccfr::io::scene
