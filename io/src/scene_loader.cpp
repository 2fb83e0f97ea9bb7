#include "ccfr/io/scene_loader.hpp"

#include <unistd.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <set>
#include <sstream>
#include <unordered_map>

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/parser.h>

#include "ccfr/collision/broad_phase.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/process.hpp"
#include "ccfr/feasibility/projector.hpp"
#include "ccfr/geometry/generators.hpp"
#include "ccfr/geometry/mass_properties.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/tet_mesh.hpp"
#include "ccfr/io/user_file.hpp"
#include "ccfr/solvers/contact_solver.hpp"
#include "scene_schema.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;
using schema::Context;

namespace {

Vec3 v3(const YAML::Node& n) { return Vec3(n[0].as<double>(), n[1].as<double>(), n[2].as<double>()); }

/// Geometry of one object before placement.
struct RawGeometry {
  Positions v;
  std::vector<Vec3i> faces;
  std::vector<Vec4i> tets;
  std::vector<std::vector<Index>> lines;
  AnalyticShape shape;
};

/// Element counts of one object (or a whole scene), in doubles: products of 32-bit keys must not
/// wrap; and the contact units of io::memory_model.
struct Counts {
  double v = 0, f = 0, t = 0, e = 0;  ///< vertices, surface faces, tets, strand segments
  double sv = 0;                      ///< vertices that collide (a tet solid: its boundary's)
  double bv = 0, bf = 0;              ///< of those, the vertices and faces of rigid bodies and obstacles
  double driven = 0;                  ///< a surface moved by scripted pins, wound onto itself: sv (1 + D / h)²
  double strand = 0;                  ///< self-contact units of strands: sv (1 + D / h)
  double fine = 0;                    ///< a surface finer than D pairs with itself where flat: sv (D / h)²
  double grains = 0;                  ///< particles: how many others each has within D, summed
  double cross = 0;                   ///< contact with other objects (a deformable on either side)
  double patch = 0;                   ///< a rigid body's contact patch with another body
  double h = 0;                       ///< mean edge length of what collides (not summed)
  double rho = 0;                     ///< bodies: 3 volume / area of a closed surface; 0 if open (not summed)
  double area = 0;                    ///< collision surface area (strands: sv h²; not summed)
  Counts& operator+=(const Counts& o) {
    v += o.v, sv += o.sv, f += o.f, t += o.t, e += o.e, bv += o.bv, bf += o.bf;
    driven += o.driven, strand += o.strand, fine += o.fine, grains += o.grains, cross += o.cross, patch += o.patch;
    h = 0, rho = 0, area = 0;  // per object only
    return *this;
  }
};

bool is_body(ObjectKind k) { return k == ObjectKind::rigid || k == ObjectKind::obstacle; }

/// Marks the elements of a rigid body or an obstacle: they move as a whole, so they carry no
/// material constraints and never pair with each other.
Counts as_kind(Counts c, ObjectKind kind) {
  if (is_body(kind)) c.bv = c.v, c.bf = c.f, c.driven = c.strand = c.fine = 0;
  return c;
}

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

/// Why a name cannot be written as `o name` in the OBJ frames (empty when it can).
std::string name_problem(const std::string& name, bool whitespace_matters) {
  if (std::string why = text_problem(name); !why.empty()) return why;  // run.json and the frames are UTF-8
  if (!whitespace_matters) return "";
  if (name.find_first_not_of(" ") == std::string::npos) return "is empty or only whitespace";
  if (name.front() == ' ' || name.back() == ' ') return "starts or ends with a space";
  return "";
}

Motion read_motion(const YAML::Node& m) {
  Motion mo;
  if (!m) return mo;
  mo.velocity = v3(m["velocity"]);
  mo.axis = v3(m["axis"]);
  mo.center = v3(m["center"]);
  mo.angular_velocity = m["angular_velocity"].as<double>();
  mo.start = m["start"].as<double>();
  mo.end = m["end"].as<double>();
  return mo;
}

/// `pattern` with its one %d / %0Nd field replaced by `number`; nullopt unless it has exactly one.
std::optional<std::string> sequence_name(const std::string& pattern, long number) {
  std::string out;
  int fields = 0;
  for (size_t i = 0; i < pattern.size(); ++i) {
    if (pattern[i] != '%') {
      out += pattern[i];
      continue;
    }
    if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
      out += '%';
      ++i;
      continue;
    }
    size_t j = i + 1;
    const bool zero = j < pattern.size() && pattern[j] == '0';
    size_t width = 0;
    while (j < pattern.size() && std::isdigit(static_cast<unsigned char>(pattern[j])) && width < 100)
      width = width * 10 + static_cast<size_t>(pattern[j++] - '0');
    if (j >= pattern.size() || pattern[j] != 'd' || ++fields > 1) return std::nullopt;
    std::string n = std::to_string(number);
    if (n.size() < width) n.insert(0, width - n.size(), zero ? '0' : ' ');
    out += n;
    i = j;
  }
  if (fields != 1) return std::nullopt;
  return out;
}

/// The objects placed so far, with their element counts (the refusal message lists them).
struct ObjectCost {
  std::string name;
  ObjectKind kind;
  Counts counts;
};

class Builder {
 public:
  Builder(const YAML::Node& input, const YAML::Node& resolved, const Context& ctx, fs::path base_dir,
          const std::map<std::string, MeshArrays>* arrays = nullptr)
      : in_(input), cfg_(resolved), ctx_(ctx), base_(std::move(base_dir)), arrays_(arrays) {}

  Scene build() {
    Scene scene;
    auto& p = scene.params;
    read_global(p);
    const YAML::Node objs = cfg_["objects"];
    if (!objs || objs.size() == 0) ctx_.fail("objects", in_, "a scene needs at least one object");

    std::set<std::string> names;
    TopologyBuilder tb;
    std::vector<RawGeometry> geoms;
    Counts total;
    for (size_t i = 0; i < objs.size(); ++i) {
      const YAML::Node o = objs[i];
      const std::string path = "objects[" + std::to_string(i) + "]";
      const std::string name = o["name"].as<std::string>();
      if (const std::string why = name_problem(name, true); !why.empty())
        ctx_.fail(path + ".name", in_node(path + ".name"),
                  "object name '" + printable(name) + "' " + why + "; it is written as `o name` in the OBJ frames");
      if (!names.insert(name).second)
        ctx_.fail(path + ".name", in_node(path + ".name"), "duplicate object name '" + name + "'");
      const ObjectKind kind = *object_kind_from_string(o["kind"].as<std::string>());
      // Refuse what cannot fit before generating it: counts are predicted from the shape's keys.
      const std::string spath = path + ".shape";
      check_size(total, predict(o["shape"], kind), spath, name, kind);
      RawGeometry g;
      try {
        g = make_geometry(o["shape"], kind, path, o["transform"]["scale"].as<double>());
      } catch (const std::invalid_argument& e) {
        ctx_.fail(spath, in_node(spath), e.what());
      }
      check_rotation(o["transform"], path + ".transform");
      place(g, o["transform"]);
      check_placed(g.v, path, name);
      // Particles' neighbours are counted up to what the limit could hold, no further.
      const double limit = memory_limit_();
      const double grain_cap = limit > 0 ? limit / kBytesPerGrainUnit : 1e10;
      const Counts actual = counts(g, kind, reach(p), driven_by_pins(o["pins"]), grain_cap);
      check_size(total, actual, spath, name, kind);
      total += actual;
      costs_.push_back({name, kind, actual});
      tb.add_object(name, kind, static_cast<Index>(g.v.size()), g.faces, g.tets, g.lines);
      geoms.push_back(std::move(g));
    }
    charge_contact(total, reach(p), p.contact.offset);
    if (log::enabled(log::Level::debug)) {
      std::string detail;
      for (const ObjectCost& c : costs_)
        detail += ccfr::format(
            "; '{}' {} v={} sv={} f={} t={} e={} h={:.4g} area={:.4g} rho={:.4g} driven={:.0f} "
            "strand={:.0f} fine={:.0f} grains={:.0f} cross={:.0f} patch={:.0f}: {:.1f} MB",
            printable(c.name), to_string(c.kind), c.counts.v, c.counts.sv, c.counts.f, c.counts.t, c.counts.e,
            c.counts.h, c.counts.area, c.counts.rho, c.counts.driven, c.counts.strand, c.counts.fine, c.counts.grains,
            c.counts.cross, c.counts.patch, object_bytes(c.counts) / 1e6);
      log::debug("{}: estimated memory {:.1f} MB ({} vertices{}), limit {}", ctx_.file, estimate_bytes(total) / 1e6,
                 count_str(total.v), detail, gigabytes(memory_limit_()));
    }
    // The contact term needs every object: the whole scene is held to the limit once more.
    check_total(total);
    scene.topo = tb.finish();

    auto& st = scene.state;
    st.resize(scene.topo.num_vertices());
    p.objects.resize(objs.size());
    for (size_t i = 0; i < objs.size(); ++i) {
      const YAML::Node o = objs[i];
      const std::string path = "objects[" + std::to_string(i) + "]";
      const auto& info = scene.topo.objects[i];
      auto& op = p.objects[i];
      for (Index k = 0; k < info.num_vertices(); ++k) st.x[info.vertex_begin + k] = geoms[i].v[k];
      op.material = material(o["material"].as<std::string>(), path + ".material");
      op.motion = read_motion(o["motion"]);
      check_motion(o["motion"], path + ".motion");
      op.initial_velocity = v3(o["velocity"]);
      op.shape = geoms[i].shape;
      if (o["animation"]) read_animation(o, info, st, op, path);
      if (o["keyframes"]) read_keyframes(o, info, st, op, path);
      for (Index v = info.vertex_begin; v < info.vertex_end; ++v) st.v[v] = op.initial_velocity;
      read_pins(o["pins"], info, st, op, path);
    }
    st.rest = st.x;
    st.x_prev = st.x;
    compute_masses(scene);
    return scene;
  }

 private:
  /// The input node at a resolved key path (for line numbers of cross-field errors).
  YAML::Node in_node(const std::string& path) const {
    YAML::Node cur;
    cur.reset(in_);
    std::string seg;
    std::stringstream ss(path);
    while (std::getline(ss, seg, '.')) {
      std::string key = seg;
      std::vector<size_t> idx;
      const auto br = seg.find('[');
      if (br != std::string::npos) {
        key = seg.substr(0, br);
        for (size_t b = br; b != std::string::npos; b = seg.find('[', b + 1))
          idx.push_back(std::stoul(seg.substr(b + 1)));
      }
      if (!cur.IsMap() || !cur[key]) return cur;
      YAML::Node next = cur[key];
      cur.reset(next);
      for (size_t k : idx) {
        if (!cur.IsSequence() || k >= cur.size()) return cur;
        YAML::Node nn = cur[k];
        cur.reset(nn);
      }
    }
    return cur;
  }

  /// Element counts a generator will make, from the shape's keys (0 for a mesh, unknown until read).
  static Counts predict(const YAML::Node& s, ObjectKind kind) {
    const std::string type = s["type"].as<std::string>();
    auto i = [](const YAML::Node& n) { return n.as<double>(); };
    Counts c;
    if (type == "grid" || type == "plane") {
      const double rx = type == "grid" ? i(s["resolution"][0]) : i(s["resolution"]);
      const double rz = type == "grid" ? i(s["resolution"][1]) : rx;
      c.v = (rx + 1) * (rz + 1), c.f = 2 * rx * rz;
    } else if (type == "strands") {
      c.v = i(s["count"]) * i(s["vertices"]), c.e = i(s["count"]) * (i(s["vertices"]) - 1);
    } else if (type == "particles") {
      c.v = i(s["counts"][0]) * i(s["counts"][1]) * i(s["counts"][2]);
    } else if (type == "tet_box") {
      const double x = i(s["resolution"][0]), y = i(s["resolution"][1]), z = i(s["resolution"][2]);
      c.v = (x + 1) * (y + 1) * (z + 1), c.t = 6 * x * y * z, c.f = 4 * (x * y + y * z + z * x);
    } else if (type == "octopus") {
      const double b = i(s["body"]), cells = b * b * b + 2 * i(s["legs"]) * i(s["leg_length"]);
      c.v = 8 * cells, c.t = 6 * cells, c.f = 12 * cells;
    } else if (type == "comb") {
      c.v = 8 * (i(s["teeth"]) + 1), c.f = 12 * (i(s["teeth"]) + 1);
    } else if (type == "cylinder") {
      c.v = 2 * i(s["segments"]) + 2, c.f = 4 * i(s["segments"]);
    }
    return as_kind(c, kind);
  }

  /// The detection reach D = 2r + ξ + δ: how far apart two primitives can be and still pair.
  static double reach(const SimulationParams& p) {
    return 2 * p.contact.radius + p.contact.offset + p.contact.repulsion_range;
  }

  /// True if a pin group of `pins` (resolved) is moved by a script: such a sheet can be wound
  /// onto itself (the twisting cloth becomes a rope), so its self-contact is charged as driven.
  static bool driven_by_pins(const YAML::Node& pins) {
    if (!pins || !pins.IsSequence()) return false;
    for (const auto& pn : pins)
      if (pn["motion"] && read_motion(pn["motion"]).moves()) return true;
    return false;
  }

  /// Element counts of generated or loaded geometry, with its collision surface (area, mean edge
  /// h) and its self-contact units for reach D (io::memory_model).
  static Counts counts(const RawGeometry& g, ObjectKind kind, double reach, bool driven, double grain_cap) {
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
    if (c.h > 0 && !is_body(kind))
      for (size_t k = 0; k < g.v.size(); ++k) {
        if (vn[k] == 0 || vsum[k] <= 0) continue;
        const double q = reach * vn[k] / vsum[k];
        if (kind == ObjectKind::strand) {
          c.strand += 1 + q;
        } else {
          c.fine += q * q;
          if (driven) c.driven += (1 + q) * (1 + q);
        }
      }
    if (kind == ObjectKind::particles) c.grains = neighbours_within(g.v, reach, grain_cap);
    if (is_body(kind)) c.rho = body_radius(g);
    return as_kind(c, kind);
  }

  /// Sum over the points of how many others lie within `reach` (each pair counted from both
  /// sides), by hashing them into cells of that size: a block of particles pairs with itself
  /// from the first frame, and a pile packs no looser.
  /// Counting stops once it passes `stop_at` (what the memory limit allows: such a scene is refused
  /// anyway), so that a million particles packed far below the reach cannot stall the loader.
  static double neighbours_within(const Positions& x, double reach, double stop_at) {
    if (x.size() < 2 || !(reach > 0)) return 0;
    std::unordered_map<std::uint64_t, std::vector<Index>> cells;
    auto key = [](std::int64_t i, std::int64_t j, std::int64_t k) {
      return (std::uint64_t(i & 0x1fffff) << 42) | (std::uint64_t(j & 0x1fffff) << 21) | std::uint64_t(k & 0x1fffff);
    };
    // The key wraps the cell indices into 21 bits each, which only merges far cells into one
    // bucket (their points fail the distance test), never misses a neighbour.
    auto index = [reach](double v) {
      return std::int64_t(std::clamp(std::floor(v / reach), -4.0e18, 4.0e18));  // a tiny reach must not overflow
    };
    auto cell = [&](const Vec3& p) -> std::array<std::int64_t, 3> {
      return {index(p.x()), index(p.y()), index(p.z())};
    };
    for (size_t a = 0; a < x.size(); ++a) {
      const auto c = cell(x[a]);
      cells[key(c[0], c[1], c[2])].push_back(static_cast<Index>(a));
    }
    double n = 0;
    const double r2 = reach * reach;
    for (size_t a = 0; a < x.size(); ++a) {
      const auto c = cell(x[a]);
      for (int di = -1; di <= 1; ++di)
        for (int dj = -1; dj <= 1; ++dj)
          for (int dk = -1; dk <= 1; ++dk) {
            const auto it = cells.find(key(c[0] + di, c[1] + dj, c[2] + dk));
            if (it == cells.end()) continue;
            for (const Index b : it->second)
              if (b != Index(a) && (x[b] - x[a]).squaredNorm() <= r2) n += 1;
          }
      if (n > stop_at) return n;
    }
    return n;
  }

  /// 3 V / A of a closed triangle surface (every edge in exactly two faces): the radius of a
  /// sphere, 1.5 times a long tube's. 0 when the surface is open (it can be touched all over).
  static double body_radius(const RawGeometry& g) {
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

  /// Fails when `add` (object `name`) does not fit 32-bit indices or the scene would need more
  /// memory than the limit: max_memory if set, else what the machine has available.
  void check_size(const Counts& before, const Counts& add, const std::string& spath, const std::string& name,
                  ObjectKind kind) const {
    Counts all = before;
    all += add;
    constexpr double kMax = std::numeric_limits<Index>::max();
    const std::pair<double, const char*> counts[] = {
        {add.v, "vertices"}, {add.f, "faces"}, {add.t, "tets"}, {add.e, "segments"}};
    for (const auto& [n, what] : counts)
      if (n > kMax)
        ctx_.fail(spath, in_node(spath),
                  "makes " + count_str(n) + " " + what + ", more than the " + count_str(kMax) +
                      " that 32-bit indices address");
    if (all.v > kMax)
      ctx_.fail(spath, in_node(spath),
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
  void charge_contact(Counts& total, double reach, double offset) {
    const auto is_sheet = [](ObjectKind k) { return k == ObjectKind::cloth || k == ObjectKind::shell; };
    const double sheets = static_cast<double>(
        std::count_if(costs_.begin(), costs_.end(), [&](const auto& c) { return is_sheet(c.kind); }));
    for (size_t i = 0; i < costs_.size(); ++i) {
      Counts& ci = costs_[i].counts;
      const ObjectKind ki = costs_[i].kind;
      if (ki == ObjectKind::obstacle) continue;  // its vertices never move: no half-space of its own
      const double layers =
          is_sheet(ki) ? layers_within_reach(ci.h, reach, offset, sheets - 1) : two_sides(reach, offset);
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
          const double share = ci.area > 0 && cj.area > 0 ? std::min(1.0, cj.area / ci.area) : 1.0;
          cross += share * f, cover += share;
        }
      }
      if (cover > layers) cross *= layers / cover;
      ci.cross = ci.sv * cross, ci.patch = patch;
      total.cross += ci.cross, total.patch += ci.patch;
    }
  }

  /// A sheet's two sides, one layer each; fewer when D < ξ cannot hold them.
  static double two_sides(double reach, double offset) { return std::min(2.0, std::max(1.0, 2.0 * reach / offset)); }

  /// How many partner layers (in units of the nearest one) a sheet of mean edge h can hold within
  /// reach D in a stack of sheets, layers being kept at least ξ apart: on each side the k-th sits
  /// at k ξ, k = 1 .. floor(D / ξ), and holds the primitives within a disc of radius √(D² − (k
  /// ξ)²), about (h + √(D² − (k ξ)²))² / h² of them. A landed pile of cloths packs 2-3 per side
  /// (docs/performance.md, the 50 layers); one per side when D < 2ξ, and never more per side than
  /// there are other sheets. Other kinds keep two_sides: they do not stack in layers.
  static double layers_within_reach(double h, double reach, double offset, double other_sheets) {
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

  /// The whole scene against the limit, once every object and its contact term are known.
  void check_total(const Counts& total) const { refuse_if_too_large(total, costs_, "objects"); }

  void refuse_if_too_large(const Counts& all, const std::vector<ObjectCost>& costs, const std::string& spath) const {
    const double need = estimate_bytes(all), have = memory_limit_();
    if (have > 0 && need > have) {
      ctx_.fail(spath, in_node(spath),
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
  double memory_limit_() const {
    if (available_ < 0) {
      available_ = max_memory_gb_ > 0 ? max_memory_gb_ * 1e9 : available_memory_bytes();
      if (const char* cap = std::getenv("CCFR_MEMORY_LIMIT_MB")) {
        const double mb = std::atof(cap);
        if (mb > 0) available_ = available_ > 0 ? std::min(available_, mb * 1e6) : mb * 1e6;
      }
    }
    return available_;
  }

  void read_global(SimulationParams& p) {
    p.scene_name = cfg_["scene"] ? cfg_["scene"].as<std::string>() : std::string("scene");
    max_memory_gb_ = cfg_["max_memory"].as<double>();
    if (const std::string why = name_problem(p.scene_name, false); !why.empty())
      ctx_.fail("scene", in_node("scene"), "scene name '" + printable(p.scene_name) + "' " + why);
    const auto t = cfg_["time"];
    p.time.fps = t["fps"].as<double>();
    p.time.frames = t["frames"].as<int>();
    p.time.substeps = t["substeps"].as<int>();
    p.time.iterations = t["iterations"].as<int>();
    p.time.xpbd_sweeps = t["xpbd_sweeps"].as<int>();
    p.time.gravity = v3(t["gravity"]);
    p.time.damping = t["damping"].as<double>();
    p.time.advance_tolerance = t["advance_tolerance"].as<double>();
    p.time.advance_shortfall = t["advance_shortfall"].as<double>();
    p.time.continuation = t["continuation"].as<std::string>() == "held_back" ? TimeParams::Continuation::held_back
                                                                             : TimeParams::Continuation::full;
    p.time.max_subdivision = t["max_subdivision"].as<int>();
    p.time.max_iterations = t["max_iterations"].as<int>();
    const auto c = cfg_["contact"];
    p.contact.solver = c["solver"].as<std::string>();
    p.contact.radius = c["radius"].as<double>();
    p.contact.offset = c["offset"].as<double>();
    p.contact.repulsion_range = c["repulsion_range"].as<double>();
    p.contact.stiffness = c["stiffness"].as<double>();
    p.contact.visibility_width = c["visibility_width"].as<double>();
    p.contact.friction_static = c["friction"]["static"].as<double>();
    p.contact.friction_kinetic = c["friction"]["kinetic"].as<double>();
    p.contact.epsilon = c["epsilon"].as<double>();
    p.contact.analytic_obstacles = c["analytic_obstacles"].as<bool>();
    const std::string policy = c["on_violation"].as<std::string>();
    p.contact.on_violation = policy == "error"  ? ViolationPolicy::error
                             : policy == "warn" ? ViolationPolicy::warn
                                                : ViolationPolicy::automatic;
    p.contact.solver_params = component_params(contact_solvers(), "contact", "solver");
    p.collision.broad_phase = cfg_["collision"]["broad_phase"].as<std::string>();
    p.collision.broad_phase_params = component_params(broad_phases(), "collision", "broad_phase");
    p.collision.reuse_skin = cfg_["collision"]["reuse_skin"].as<double>();
    const auto d = cfg_["debug"];
    const std::string audit = d["audit"].as<std::string>();
    p.debug.audit = audit == "every_frame"     ? AuditMode::every_frame
                    : audit == "every_substep" ? AuditMode::every_substep
                                               : AuditMode::off;
    p.debug.audit_tolerance = d["audit_tolerance"].as<double>();
    p.output.frames = cfg_["output"]["frames"].as<bool>();
    p.output.every = cfg_["output"]["every"].as<int>();
    p.output.checkpoint_every = cfg_["output"]["checkpoint_every"].as<int>();
    if (const YAML::Node fm = cfg_["output"]["formats"]) {
      for (size_t k = 0; k < fm.size(); ++k) p.output.formats.push_back(fm[k].as<std::string>());
      if (p.output.formats.empty())
        ctx_.fail("output.formats", in_node("output.formats"), "list at least one format (obj, ply, vtu, pc2, usda)");
    }
    if (p.contact.friction_kinetic > p.contact.friction_static && p.contact.friction_static > 0)
      ctx_.fail("contact.friction.kinetic", in_node("contact.friction.kinetic"),
                "kinetic friction must not exceed static friction", {"contact.friction.static"});
  }

  /// The parameters of the component that `section.selector` names, from its section
  /// `section.<name>.*`. A section set in the input for another component is an error: its values
  /// would silently do nothing.
  template <class R>
  ParamValues component_params(const R& registry, const std::string& section, const std::string& selector) {
    const std::string chosen = cfg_[section][selector].template as<std::string>();
    const YAML::Node given = in_[section];
    for (const auto& e : registry.entries()) {
      if (e.name == chosen || e.params.empty() || !given || !given.IsMap() || !given[e.name]) continue;
      const std::string path = section + "." + e.name;
      ctx_.fail(path, in_node(path),
                "parameters of " + registry.kind() + " '" + e.name + "' are set, but " + section + "." + selector +
                    " is '" + chosen + "'; remove the section or set " + section + "." + selector + ": " + e.name,
                {section + "." + selector});
    }
    ParamValues v;
    const auto* entry = registry.find(chosen);
    if (!entry) return v;  // the schema's choice already rejected unknown names
    for (const auto& spec : entry->params) {
      const YAML::Node n = cfg_[section][chosen][spec.key];
      switch (spec.type) {
        case ParamType::boolean:
          v.set(spec.key, n.template as<bool>());
          break;
        case ParamType::integer:
          v.set(spec.key, n.template as<long long>());
          break;
        case ParamType::number:
          v.set(spec.key, n.template as<double>());
          break;
        case ParamType::choice:
          v.set(spec.key, n.template as<std::string>());
          break;
      }
    }
    return v;
  }

  MaterialParams material(const std::string& name, const std::string& path) {
    const YAML::Node mats = cfg_["materials"];
    YAML::Node m;
    if (mats[name]) m.reset(mats[name]);
    if (!m.IsDefined() || m.IsNull()) {
      if (name != "default") {
        std::string list = "default";
        for (auto it = mats.begin(); it != mats.end(); ++it) list += ", " + it->first.as<std::string>();
        ctx_.fail(path, in_node(path), "unknown material '" + name + "'; defined: " + list);
      }
      // The implicit default material: every key at its schema default.
      m.reset(schema::resolve(YAML::Node(YAML::NodeType::Map), material_schema(), ctx_, "materials.default"));
    }
    MaterialParams mp;
    mp.density = m["density"].as<double>();
    mp.stretch_compliance = m["stretch_compliance"].as<double>();
    mp.bend_compliance = m["bend_compliance"].as<double>();
    mp.volume_compliance = m["volume_compliance"].as<double>();
    mp.shear_compliance = m["shear_compliance"].as<double>();
    mp.friction = m["friction"].as<double>();
    return mp;
  }

  /// `scale`: the object's transform.scale, applied after this (place): tetgen's volume bound is
  /// in the file's units, so shape.max_volume (m³) is divided by scale³ for it.
  RawGeometry make_geometry(const YAML::Node& s, ObjectKind kind, const std::string& path, double scale = 1.0) {
    const std::string type = s["type"].as<std::string>();
    const std::string tpath = path + ".shape.type";
    auto require = [&](bool ok, const std::string& what) {
      if (!ok)
        ctx_.fail(tpath, in_node(tpath),
                  "shape '" + type + "' cannot make a " + std::string(to_string(kind)) + " object; " + what,
                  {path + ".kind"});
    };
    const bool surface_kind = kind == ObjectKind::cloth || kind == ObjectKind::shell || kind == ObjectKind::obstacle ||
                              kind == ObjectKind::rigid;
    RawGeometry g;
    auto take = [&](gen::TriMesh m) {
      g.v = std::move(m.v);
      g.faces = std::move(m.f);
    };
    if (type == "grid") {
      require(surface_kind, "use kind cloth, shell, obstacle or rigid");
      take(gen::grid(s["size"][0].as<double>(), s["size"][1].as<double>(), s["resolution"][0].as<Index>(),
                     s["resolution"][1].as<Index>()));
      if (kind == ObjectKind::obstacle) {
        // A flat obstacle grid is also an analytic plane (normal +y) for the SDF pass.
        g.shape.type = AnalyticShape::Type::plane;
      }
    } else if (type == "strands") {
      require(kind == ObjectKind::strand, "use kind strand");
      auto ps = gen::curly_strands(s["count"].as<Index>(), s["vertices"].as<Index>(), s["length"].as<double>(),
                                   s["spread"].as<double>(), s["coil_radius"].as<double>(), s["turns"].as<double>(),
                                   s["layout"].as<std::string>() == "row");
      g.v = std::move(ps.v);
      g.lines = std::move(ps.lines);
    } else if (type == "particles") {
      require(kind == ObjectKind::particles, "use kind particles");
      const auto c = s["counts"];
      g.v = gen::particle_block(c[0].as<Index>(), c[1].as<Index>(), c[2].as<Index>(), s["spacing"].as<double>());
    } else if (type == "tet_box") {
      require(kind == ObjectKind::tet_solid, "use kind tet_solid");
      const auto r = s["resolution"];
      auto m = gen::tet_box(v3(s["size"]), Vec3i(r[0].as<Index>(), r[1].as<Index>(), r[2].as<Index>()));
      g.v = std::move(m.v);
      g.tets = std::move(m.t);
    } else if (type == "octopus") {
      require(kind == ObjectKind::tet_solid, "use kind tet_solid");
      auto m = gen::octopus(s["cell"].as<double>(), s["body"].as<Index>(), s["legs"].as<Index>(),
                            s["leg_length"].as<Index>());
      g.v = std::move(m.v);
      g.tets = std::move(m.t);
    } else if (type == "comb") {
      require(surface_kind, "use kind obstacle, rigid, shell or cloth");
      take(gen::comb(s["length"].as<double>(), s["width"].as<double>(), s["spine_height"].as<double>(),
                     s["teeth"].as<Index>(), s["tooth_length"].as<double>(), s["tooth_width"].as<double>()));
    } else if (type == "sphere") {
      require(surface_kind, "use kind obstacle, rigid, shell or cloth");
      take(gen::sphere(s["radius"].as<double>(), s["subdivisions"].as<int>()));
      g.shape.type = AnalyticShape::Type::sphere;
      g.shape.radius = s["radius"].as<double>();
    } else if (type == "cylinder") {
      require(surface_kind, "use kind obstacle, rigid, shell or cloth");
      take(gen::cylinder(s["radius"].as<double>(), s["height"].as<double>(), s["segments"].as<Index>(),
                         s["capped"].as<bool>()));
      g.shape.type = AnalyticShape::Type::cylinder;
      g.shape.radius = s["radius"].as<double>();
      g.shape.half_height = 0.5 * s["height"].as<double>();
    } else if (type == "box" || type == "open_box") {
      require(surface_kind, "use kind obstacle, rigid, shell or cloth");
      const Vec3 size = v3(s["size"]);
      if ((size.array() <= 0).any())
        ctx_.fail(path + ".shape.size", in_node(path + ".shape.size"), "box sizes must be > 0");
      take(type == "box" ? gen::box(size) : gen::open_box(size));
      if (type == "box") {
        g.shape.type = AnalyticShape::Type::box;
        g.shape.half_extent = 0.5 * size;
      }
    } else if (type == "plane") {
      require(surface_kind, "use kind obstacle, shell or cloth");
      take(gen::plane(s["size"].as<double>(), s["resolution"].as<Index>()));
      g.shape.type = AnalyticShape::Type::plane;
    } else if (type == "mesh" && arrays_ && arrays_->count(s["path"].as<std::string>())) {
      g = array_geometry(arrays_->at(s["path"].as<std::string>()), kind, path, [&](bool ok, const std::string& what) {
        if (!ok)
          ctx_.fail(path + ".kind", in_node(path + ".kind"),
                    "arrays cannot make a " + std::string(to_string(kind)) + " object: " + what);
      });
      if (kind != ObjectKind::obstacle) g.shape.type = AnalyticShape::Type::none;
      return g;
    } else if (type == "mesh") {
      const std::string ppath = path + ".shape.path";
      fs::path file = s["path"].as<std::string>();
      std::string ext = file.extension().string();
      for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      const auto& exts = mesh_extensions();
      if (std::find(exts.begin(), exts.end(), ext) == exts.end()) {
        std::string list;
        for (const auto& e : exts) list += (list.empty() ? "" : ", ") + e;
        ctx_.fail(ppath, in_node(ppath),
                  ext.empty()
                      ? "mesh file '" + file.string() + "' has no extension (supported: " + list + ")"
                      : "unsupported mesh format '" + file.extension().string() + "' (supported: " + list + ")");
      }
      if (file.is_relative()) file = base_ / file;
      fs::file_status st;
      try {
        st = user_path_status(file, "mesh file");
      } catch (const Error& e) {
        ctx_.fail(ppath, in_node(ppath), e.what());
      }
      if (st.type() == fs::file_type::not_found && ext != ".node" && ext != ".ele")
        ctx_.fail(ppath, in_node(ppath), "mesh file '" + file.string() + "' does not exist");
      const bool surface_file = ext == ".obj" || ext == ".off";
      if (!surface_file) {
        require(kind == ObjectKind::tet_solid, "a tet mesh (" + ext + ") makes a tet_solid object");
        TetMesh m;
        try {
          m = ext == ".msh" ? read_gmsh(file) : read_tetgen(file);
        } catch (const Error& e) {
          ctx_.fail(ppath, in_node(ppath), std::string("cannot read mesh: ") + e.what());
        }
        g.v = std::move(m.v);
        g.tets = std::move(m.t);
        return g;
      }
      ObjMesh m;
      try {
        m = ext == ".off" ? read_off_mesh(file) : read_obj_mesh(file);
      } catch (const Error& e) {
        ctx_.fail(ppath, in_node(ppath), std::string("cannot read mesh: ") + e.what());
      }
      if (kind == ObjectKind::tet_solid) {
        // A closed surface filled with tets by the tetgen program.
        if (m.f.empty()) ctx_.fail(ppath, in_node(ppath), "mesh '" + file.string() + "' has no faces");
        check_faces(m.v, m.f, ObjectKind::tet_solid, "mesh '" + file.string() + "'", &m.face_lines, ppath,
                    {path + ".kind"});
        TetMesh t;
        try {
          t = tetrahedralize(m.v, m.f, s["quality"].as<double>(),
                             s["max_volume"].as<double>() / (scale * scale * scale), "mesh '" + file.string() + "'");
        } catch (const Error& e) {
          ctx_.fail(ppath, in_node(ppath), e.what());
        }
        g.v = std::move(t.v);
        g.tets = std::move(t.t);
        return g;
      }
      g.v = std::move(m.v);
      // Elements the object would not use are refused, naming their line, rather than dropped.
      const auto unused = [&](int line, const std::string& what) {
        if (line > 0)
          ctx_.fail(ppath, in_node(ppath),
                    "'" + printable(file.string()) + "' line " + std::to_string(line) + ": " + what + " (kind " +
                        std::string(to_string(kind)) + " would drop them); remove them from the mesh",
                    {path + ".kind"});
      };
      unused(m.first_point_line, "`p` points are not read from mesh files");
      if (kind == ObjectKind::strand) {
        if (m.lines.empty())
          ctx_.fail(ppath, in_node(ppath), "a strand mesh needs `l` lines; '" + file.string() + "' has none");
        if (!m.face_lines.empty()) unused(m.face_lines.front(), "`f` faces make no strands");
        g.lines = std::move(m.lines);
      } else {
        unused(m.first_line_line, "`l` lines are strands, not part of a surface");
        require(surface_kind, "meshes make cloth, shell, obstacle, rigid or strand objects");
        if (m.f.empty()) ctx_.fail(ppath, in_node(ppath), "mesh '" + file.string() + "' has no faces");
        check_faces(g.v, m.f, kind, "mesh '" + file.string() + "'", &m.face_lines, ppath, {path + ".kind"});
        g.faces = std::move(m.f);
      }
    }
    if (type != "mesh" && !g.faces.empty()) {
      check_faces(g.v, g.faces, kind, "shape '" + type + "'", nullptr, tpath, {path + ".kind"});
    }
    if (kind != ObjectKind::obstacle) g.shape.type = AnalyticShape::Type::none;  // only obstacles collide analytically
    return g;
  }

  /// Degenerate surfaces: faces that repeat a vertex, have no area or repeat another face, edges
  /// shared by more than two faces, and open surfaces used as rigid bodies (whose mass comes from
  /// the enclosed volume). Errors name the face (1-based, after triangulation) and its OBJ line;
  /// what a user may reasonably want (zero-area obstacle faces, non-manifold cloth) is a warning.
  void check_faces(const Positions& v, const std::vector<Vec3i>& faces, ObjectKind kind, const std::string& what,
                   const std::vector<int>* lines, const std::string& path,
                   const std::vector<std::string>& related) const {
    auto face = [&](size_t i) {
      std::string w = "face " + std::to_string(i + 1);
      if (lines && i < lines->size()) w += " (line " + std::to_string((*lines)[i]) + ")";
      return w;
    };
    auto fail = [&](const std::string& msg) { ctx_.fail(path, in_node(path), what + ": " + msg, related); };
    const bool rigid = kind == ObjectKind::rigid;
    // A rigid body's mass and a tet_solid's tets both come from the enclosed volume.
    const bool solid = rigid || kind == ObjectKind::tet_solid;
    size_t zero_area = 0, first_zero = 0;
    for (size_t i = 0; i < faces.size(); ++i) {
      const Vec3i& f = faces[i];
      if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2])
        fail(face(i) + " repeats vertex " + std::to_string((f[0] == f[1] || f[0] == f[2] ? f[0] : f[1]) + 1));
      const Vec3 e1 = v[f[1]] - v[f[0]], e2 = v[f[2]] - v[f[0]], e3 = v[f[2]] - v[f[1]];
      const double l2 = std::max({e1.squaredNorm(), e2.squaredNorm(), e3.squaredNorm()});
      if (!(e1.cross(e2).norm() > 1e-12 * l2) || l2 == 0.0) {
        if (zero_area++ == 0) first_zero = i;
      }
    }
    if (zero_area > 0) {
      const std::string msg = face(first_zero) + " has zero area (its vertices coincide or are collinear)" +
                              (zero_area > 1 ? "; " + std::to_string(zero_area) + " such faces in all" : std::string());
      if (kind != ObjectKind::obstacle) fail(msg);
      log::warn("{}: {}: {}: {}", ctx_.file, path, what, msg);
    }
    // Duplicate faces (the same three vertices in any order).
    std::vector<std::pair<std::array<Index, 3>, size_t>> sorted(faces.size());
    for (size_t i = 0; i < faces.size(); ++i) {
      std::array<Index, 3> k{faces[i][0], faces[i][1], faces[i][2]};
      std::sort(k.begin(), k.end());
      sorted[i] = {k, i};
    }
    std::sort(sorted.begin(), sorted.end());
    for (size_t i = 1; i < sorted.size(); ++i)
      if (sorted[i].first == sorted[i - 1].first)
        fail(face(sorted[i].second) + " repeats " + face(sorted[i - 1].second));
    // Edge valence: 2 everywhere on a closed manifold surface.
    std::vector<std::pair<std::pair<Index, Index>, size_t>> edges;
    edges.reserve(3 * faces.size());
    for (size_t i = 0; i < faces.size(); ++i)
      for (int k = 0; k < 3; ++k) edges.push_back({std::minmax(faces[i][k], faces[i][(k + 1) % 3]), i});
    std::sort(edges.begin(), edges.end());
    size_t non_manifold = 0, open = 0, first_nm = 0, first_open = 0;
    std::pair<Index, Index> nm_edge, open_edge;
    for (size_t b = 0; b < edges.size();) {
      size_t e = b;
      while (e < edges.size() && edges[e].first == edges[b].first) ++e;
      if (e - b > 2 && non_manifold++ == 0) first_nm = edges[b + 2].second, nm_edge = edges[b].first;
      if (e - b == 1 && open++ == 0) first_open = edges[b].second, open_edge = edges[b].first;
      b = e;
    }
    auto edge_str = [](std::pair<Index, Index> e) {
      return "(" + std::to_string(e.first + 1) + ", " + std::to_string(e.second + 1) + ")";
    };
    if (non_manifold > 0) {
      const std::string msg =
          "edge " + edge_str(nm_edge) + " of " + face(first_nm) + " is shared by more than two faces (non-manifold)" +
          (non_manifold > 1 ? "; " + std::to_string(non_manifold) + " such edges in all" : std::string());
      if (solid) fail(msg);
      log::warn("{}: {}: {}: {}", ctx_.file, path, what, msg);
    }
    const std::string needs = rigid ? "a rigid body needs a closed surface (its mass comes from the enclosed volume)"
                                    : "a tet_solid from a surface needs a closed surface (tetgen fills the inside)";
    if (solid && open > 0)
      fail(needs + ", but edge " + edge_str(open_edge) + " of " + face(first_open) + " borders only one face (" +
           std::to_string(open) + " open edges in all)");
    if (!solid) return;
    // Consistent winding: on a closed oriented surface every edge runs once each way.
    for (size_t b = 0; b + 1 < edges.size(); b += 2) {
      const Vec3i& f = faces[edges[b].second];
      const Vec3i& g = faces[edges[b + 1].second];
      auto runs_forward = [&](const Vec3i& t) {
        for (int k = 0; k < 3; ++k)
          if (t[k] == edges[b].first.first && t[(k + 1) % 3] == edges[b].first.second) return true;
        return false;
      };
      if (runs_forward(f) == runs_forward(g))
        fail(face(edges[b + 1].second) + " is wound against " + face(edges[b].second) + " (their common edge " +
             edge_str(edges[b].first) + " runs the same way in both); orient all faces outward");
    }
    const SolidMassProperties props = solid_mass_properties(v, faces);
    Vec3 lo = v[faces[0][0]], hi = lo;
    for (const Vec3i& f : faces)
      for (int k = 0; k < 3; ++k) lo = lo.cwiseMin(v[f[k]]), hi = hi.cwiseMax(v[f[k]]);
    const double diagonal = (hi - lo).norm();
    if (!(props.volume > 1e-9 * diagonal * diagonal * diagonal))
      fail(
          ccfr::format("the closed surface encloses no volume ({:.3g} m³ inside a bounding box of diagonal {:.3g} m): "
                       "a flat surface cannot be a solid",
                       props.volume, diagonal));
    if (props.inverted)
      log::info("{}: {}: {}: faces wound inward; taken as the solid they enclose", ctx_.file, path, what);
  }

  /// A rotation by a non-zero angle about the zero vector has no axis: it used to be skipped.
  void check_rotation(const YAML::Node& t, const std::string& tpath) const {
    if (t["rotate_deg"].as<double>() != 0.0 && v3(t["rotate_axis"]).norm() == 0.0)
      ctx_.fail(tpath + ".rotate_axis", in_node(tpath + ".rotate_axis"),
                "rotate_axis [0, 0, 0] has no direction, but rotate_deg is " + t["rotate_deg"].as<std::string>() +
                    "; give the axis to rotate about",
                {tpath + ".rotate_deg"});
  }

  /// Scripted motion moves from `start` to `end`: an end before the start would never move.
  void check_motion(const YAML::Node& m, const std::string& mpath) const {
    if (!m) return;
    if (m["end"].as<double>() < m["start"].as<double>())
      ctx_.fail(mpath + ".end", in_node(mpath + ".end"),
                "the motion ends (" + m["end"].as<std::string>() + " s) before it starts (" +
                    m["start"].as<std::string>() + " s)",
                {mpath + ".start"});
    if (v3(m["axis"]).norm() == 0.0 && m["angular_velocity"].as<double>() != 0.0)
      ctx_.fail(mpath + ".axis", in_node(mpath + ".axis"),
                "axis [0, 0, 0] has no direction, but angular_velocity is " + m["angular_velocity"].as<std::string>(),
                {mpath + ".angular_velocity"});
  }

  /// Placed coordinates beyond kMaxCoordinate (a mesh in the wrong unit, a huge scale): refused
  /// here, naming the vertex, rather than found by the renderer or the export.
  void check_placed(const Positions& v, const std::string& path, const std::string& name) const {
    for (size_t i = 0; i < v.size(); ++i)
      if (!(v[i].cwiseAbs().maxCoeff() <= kMaxCoordinate))
        ctx_.fail(path + ".transform", in_node(path),
                  "object '" + name + "': vertex " + std::to_string(i + 1) + " lies at (" +
                      ccfr::format("{:g}, {:g}, {:g}", v[i].x(), v[i].y(), v[i].z()) +
                      ") once placed, beyond +-1e6 m, ccfr's bound on coordinates (check the mesh's unit and "
                      "transform.scale)");
  }

  void place(RawGeometry& g, const YAML::Node& t) {
    const double scale = t["scale"].as<double>();
    const Vec3 axis = v3(t["rotate_axis"]);
    const double ang = t["rotate_deg"].as<double>() * std::numbers::pi / 180.0;
    const Vec3 tr = v3(t["translate"]);
    Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
    if (ang != 0.0 && axis.norm() > 0) R = Eigen::AngleAxisd(ang, axis.normalized()).toRotationMatrix();
    for (auto& v : g.v) v = R * (scale * v) + tr;
    g.shape.center = tr;
    g.shape.rotation = R;
    g.shape.radius *= scale;
    g.shape.half_height *= scale;
    g.shape.half_extent *= scale;
  }

  /// An obstacle animated by an OBJ sequence: every file read, placed by `transform` and checked
  /// against the object's vertex count; the object starts at the first file.
  void read_animation(const YAML::Node& o, const ObjectInfo& info, SimState& st, ObjectParams& op,
                      const std::string& path) {
    const YAML::Node a = o["animation"];
    const std::string apath = path + ".animation";
    if (info.kind != ObjectKind::obstacle)
      ctx_.fail(apath, in_node(apath), "only obstacles can be animated by a sequence", {path + ".kind"});
    if (op.motion.moves())
      ctx_.fail(apath, in_node(apath), "an object has either `motion` or `animation`, not both", {path + ".motion"});
    const std::string pattern = a["path"].as<std::string>();
    const double fps = a["fps"].as<double>() > 0 ? a["fps"].as<double>() : cfg_["time"]["fps"].as<double>();
    auto anim = std::make_shared<VertexAnimation>();
    for (long k = 0; k < a["count"].as<long>(); ++k) {
      const long number = a["first"].as<long>() + k;
      const std::optional<std::string> name = sequence_name(pattern, number);
      if (!name)
        ctx_.fail(apath + ".path", in_node(apath + ".path"),
                  "'" + pattern + "' needs exactly one integer field such as %d or %03d (and %% for a percent sign)");
      fs::path file = *name;
      if (file.is_relative()) file = base_ / file;
      RawGeometry g;
      try {
        g.v = read_obj_mesh(file).v;
      } catch (const Error& e) {
        ctx_.fail(apath + ".path", in_node(apath + ".path"), "file " + std::to_string(number) + ": " + e.what());
      }
      if (static_cast<Index>(g.v.size()) != info.num_vertices())
        ctx_.fail(apath + ".path", in_node(apath + ".path"),
                  "'" + file.string() + "' has " + std::to_string(g.v.size()) + " vertices, the object " +
                      std::to_string(info.num_vertices()));
      place(g, o["transform"]);
      check_placed(g.v, apath + ".path", info.name + "' (file " + std::to_string(number) + ")");
      anim->times.push_back(static_cast<double>(k) / fps);
      anim->keys.push_back(std::move(g.v));
    }
    for (Index k = 0; k < info.num_vertices(); ++k) st.x[info.vertex_begin + k] = anim->keys.front()[k];
    op.motion.animation = std::move(anim);
    op.shape.type = AnalyticShape::Type::none;  // the mesh moves on its own: no rigid analytic shape
  }

  /// An obstacle moved by keyframed rigid transforms of its placed geometry.
  void read_keyframes(const YAML::Node& o, const ObjectInfo& info, SimState& st, ObjectParams& op,
                      const std::string& path) {
    const YAML::Node keys = o["keyframes"];
    const std::string kpath = path + ".keyframes";
    if (info.kind != ObjectKind::obstacle)
      ctx_.fail(kpath, in_node(kpath), "only obstacles can be keyframed", {path + ".kind"});
    if (op.motion.moves())
      ctx_.fail(kpath, in_node(kpath), "an object has one of `motion`, `animation` and `keyframes`");
    if (keys.size() == 0) ctx_.fail(kpath, in_node(kpath), "list at least one key");
    auto anim = std::make_shared<VertexAnimation>();
    Vec3 prev_axis = Vec3::Zero();
    double prev_deg = 0;
    for (size_t k = 0; k < keys.size(); ++k) {
      const YAML::Node key = keys[k];
      const std::string p = kpath + "[" + std::to_string(k) + "]";
      const double t = key["time"].as<double>();
      if (k > 0 && !(t > anim->times.back()))
        ctx_.fail(p + ".time", in_node(p + ".time"), "key times must increase",
                  {kpath + "[" + std::to_string(k - 1) + "].time"});
      const Vec3 axis = v3(key["rotate_axis"]), c = v3(key["center"]);
      const double ang = key["rotate_deg"].as<double>() * std::numbers::pi / 180.0;
      check_rotation(key, p);
      // Keys are slerped, which takes the shorter way round (at most 180°): a turn of 180° or more
      // between two keys about one axis would run backwards (270°) or not at all (360°).
      // A key at 0° has no axis of its own (the identity): it pairs with any axis.
      const double deg = key["rotate_deg"].as<double>();
      if (k > 0 && (deg == 0.0 || prev_deg == 0.0 || (axis.norm() > 0 && prev_axis.norm() > 0))) {
        const Vec3 a = deg == 0.0 ? Vec3::UnitY() : axis.normalized();
        const Vec3 b = prev_deg == 0.0 ? a : prev_axis.normalized();
        const double sign = a.dot(b) > 0 ? 1.0 : -1.0;  // [0,-1,0] at -90° is [0,1,0] at 90°
        if (deg == 0.0 || (a - sign * b).norm() < 1e-12) {
          const double turn = deg - sign * prev_deg;
          if (std::abs(turn) >= 180.0)
            ctx_.fail(p + ".rotate_deg", in_node(p + ".rotate_deg"),
                      "turns " + ccfr::format("{:g}", turn) +
                          "° from the key before; keys are interpolated the "
                          "shorter way round (slerp, at most 180°), so this turn would not happen: split it into keys "
                          "less than 180° apart",
                      {kpath + "[" + std::to_string(k - 1) + "].rotate_deg"});
        }
      }
      prev_axis = axis;
      prev_deg = deg;
      if (k > 0 && (c - anim->center).norm() > 0)
        ctx_.fail(p + ".center", in_node(p + ".center"), "every key rotates about the same center",
                  {kpath + "[0].center"});
      anim->center = c;
      anim->times.push_back(t);
      anim->rotations.push_back(ang != 0.0 && axis.norm() > 0
                                    ? Eigen::Quaterniond(Eigen::AngleAxisd(ang, axis.normalized()))
                                    : Eigen::Quaterniond::Identity());
      anim->translations.push_back(v3(key["translate"]));
    }
    anim->rest.assign(st.x.begin() + info.vertex_begin, st.x.begin() + info.vertex_end);
    for (Index k = 0; k < info.num_vertices(); ++k) st.x[info.vertex_begin + k] = anim->at(k, 0.0);
    op.motion.animation = std::move(anim);
    op.shape.type = AnalyticShape::Type::none;
  }

  void read_pins(const YAML::Node& pins, const ObjectInfo& info, SimState& st, ObjectParams& op,
                 const std::string& path) {
    if (!pins) return;
    for (size_t k = 0; k < pins.size(); ++k) {
      const YAML::Node pn = pins[k];
      const std::string pp = path + ".pins[" + std::to_string(k) + "]";
      PinGroup grp;
      grp.motion = read_motion(pn["motion"]);
      check_motion(pn["motion"], pp + ".motion");
      if (pn["indices"])
        for (size_t j = 0; j < pn["indices"].size(); ++j) {
          const Index li = pn["indices"][j].as<Index>();
          if (li >= info.num_vertices())
            ctx_.fail(pp + ".indices[" + std::to_string(j) + "]", in_node(pp + ".indices"),
                      "vertex index " + std::to_string(li) + " out of range: the object has " +
                          std::to_string(info.num_vertices()) + " vertices");
          grp.vertices.push_back(li);
        }
      if (static_cast<bool>(pn["box_min"]) != static_cast<bool>(pn["box_max"]))
        ctx_.fail(pp, in_node(pp), "box_min and box_max go together");
      if (pn["box_min"]) {
        const Vec3 lo = v3(pn["box_min"]), hi = v3(pn["box_max"]);
        for (Index v = info.vertex_begin; v < info.vertex_end; ++v)
          if ((st.x[v].array() >= lo.array()).all() && (st.x[v].array() <= hi.array()).all())
            grp.vertices.push_back(v - info.vertex_begin);
      }
      if (grp.vertices.empty())
        ctx_.fail(pp, in_node(pp), "pin group selects no vertex (give indices or a box that contains vertices)");
      op.pins.push_back(std::move(grp));
    }
  }

  void compute_masses(Scene& scene) {
    auto& st = scene.state;
    const auto& topo = scene.topo;
    for (size_t oi = 0; oi < topo.objects.size(); ++oi) {
      const auto& o = topo.objects[oi];
      const double rho = scene.params.objects[oi].material.density;
      switch (o.kind) {
        case ObjectKind::cloth:
        case ObjectKind::shell:
          for (Index f = o.face_begin; f < o.face_end; ++f) {
            const auto& t = topo.faces[f];
            const double a = 0.5 * (st.x[t[1]] - st.x[t[0]]).cross(st.x[t[2]] - st.x[t[0]]).norm();
            for (int k = 0; k < 3; ++k) st.mass[t[k]] += rho * a / 3.0;
          }
          break;
        case ObjectKind::strand:
          for (Index l = o.polyline_begin; l < o.polyline_end; ++l) {
            const auto row = topo.polylines.row(l);
            for (size_t k = 1; k < row.size(); ++k) {
              const double len = (st.x[row[k]] - st.x[row[k - 1]]).norm();
              st.mass[row[k]] += 0.5 * rho * len;
              st.mass[row[k - 1]] += 0.5 * rho * len;
            }
          }
          break;
        case ObjectKind::tet_solid:
          for (Index t = o.tet_begin; t < o.tet_end; ++t) {
            const auto& tt = topo.tets[t];
            const double vol =
                std::abs((st.x[tt[1]] - st.x[tt[0]]).cross(st.x[tt[2]] - st.x[tt[0]]).dot(st.x[tt[3]] - st.x[tt[0]])) /
                6.0;
            for (int k = 0; k < 4; ++k) st.mass[tt[k]] += rho * vol / 4.0;
          }
          break;
        case ObjectKind::rigid: {
          // The solid's mass, centre of mass and inertia (divergence theorem) carried by the vertex
          // masses plus a core at the centre of mass, which RigidBodies adds as ρV - Σ m.
          const std::span<const Vec3> xs(st.x.data() + o.vertex_begin, static_cast<size_t>(o.num_vertices()));
          std::vector<Vec3i> local;
          local.reserve(static_cast<size_t>(o.face_end - o.face_begin));
          for (Index f = o.face_begin; f < o.face_end; ++f)
            local.push_back(topo.faces[f] - Vec3i::Constant(o.vertex_begin));
          const SolidMassProperties props = solid_mass_properties(xs, local);
          const RigidVertexMasses m = rigid_vertex_masses(xs, local, rho, props);
          for (Index v = o.vertex_begin; v < o.vertex_end; ++v) st.mass[v] = m.vertex[v - o.vertex_begin];
          if (!m.exact)
            log::info(
                "{}: objects[{}] ('{}'): its {} vertices cannot carry the solid's inertia tensor (off by {:.1f}%, "
                "e.g. every vertex on a cylinder's rim); mass {:.6g} kg and centre of mass are exact",
                ctx_.file, oi, o.name, o.num_vertices(), 100.0 * m.inertia_error, rho * props.volume);
          break;
        }
        case ObjectKind::particles:
          for (Index v = o.vertex_begin; v < o.vertex_end; ++v) st.mass[v] = rho;
          break;
        case ObjectKind::obstacle:
          break;
      }
      for (Index v = o.vertex_begin; v < o.vertex_end; ++v) {
        // Isolated vertices of a surface (no face) still need a mass to move.
        if (o.kind != ObjectKind::obstacle && st.mass[v] <= 0.0) st.mass[v] = 1e-6;
        st.inv_mass[v] = o.kind == ObjectKind::obstacle ? 0.0 : 1.0 / st.mass[v];
      }
      for (const auto& pin : scene.params.objects[oi].pins)
        for (Index lv : pin.vertices) st.inv_mass[o.vertex_begin + lv] = 0.0;
    }
  }

  /// Geometry from in-memory arrays (load_scene_arrays): the checks of a mesh file, plus those of
  /// edges and tets, which no file format of the loader carries.
  RawGeometry array_geometry(const MeshArrays& a, ObjectKind kind, const std::string& path,
                             const std::function<void(bool, const std::string&)>& require) const {
    RawGeometry g;
    const Index nv = static_cast<Index>(a.vertices.size());
    const std::string vpath = path + ".vertices";
    if (nv == 0) ctx_.fail(vpath, in_node(path), "no vertices");
    for (Index i = 0; i < nv; ++i)
      if (!a.vertices[i].allFinite()) ctx_.fail(vpath, in_node(path), "vertex " + std::to_string(i) + " is not finite");
    auto check_range = [&](const std::string& what, const auto& rows) {
      for (size_t r = 0; r < rows.size(); ++r)
        for (int k = 0; k < rows[r].size(); ++k)
          if (rows[r][k] < 0 || rows[r][k] >= nv)
            ctx_.fail(path + "." + what, in_node(path),
                      what + " row " + std::to_string(r) + ": vertex index " + std::to_string(rows[r][k]) +
                          " out of range (the object has " + std::to_string(nv) + " vertices)");
    };
    check_range("faces", a.faces);
    check_range("edges", a.edges);
    check_range("tets", a.tets);
    const bool surface_kind = kind == ObjectKind::cloth || kind == ObjectKind::shell || kind == ObjectKind::obstacle ||
                              kind == ObjectKind::rigid;
    auto only = [&](bool ok, const std::string& what) {
      if (!ok) require(false, what);
    };
    g.v = a.vertices;
    if (kind == ObjectKind::strand) {
      only(a.faces.empty() && a.tets.empty(), "a strand takes edges, not faces or tets");
      if (a.edges.empty()) ctx_.fail(path + ".edges", in_node(path), "a strand needs edges");
      for (size_t r = 0; r < a.edges.size(); ++r) {
        const Vec2i& e = a.edges[r];
        if (e[0] == e[1])
          ctx_.fail(path + ".edges", in_node(path),
                    "edges row " + std::to_string(r) + " repeats vertex " + std::to_string(e[0]));
        if (g.lines.empty() || g.lines.back().back() != e[0]) g.lines.push_back({e[0]});
        g.lines.back().push_back(e[1]);
      }
    } else if (kind == ObjectKind::tet_solid) {
      only(a.faces.empty() && a.edges.empty(), "a tet_solid takes tets (its surface is derived), not faces or edges");
      if (a.tets.empty()) ctx_.fail(path + ".tets", in_node(path), "a tet_solid needs tets");
      for (size_t r = 0; r < a.tets.size(); ++r) {
        const Vec4i& t = a.tets[r];
        const Vec3 e1 = g.v[t[1]] - g.v[t[0]], e2 = g.v[t[2]] - g.v[t[0]], e3 = g.v[t[3]] - g.v[t[0]];
        const double scale = std::max({e1.norm(), e2.norm(), e3.norm()});
        const double vol6 = e1.cross(e2).dot(e3);
        if (!(vol6 > 1e-12 * scale * scale * scale))
          ctx_.fail(path + ".tets", in_node(path),
                    "tets row " + std::to_string(r) + " has " + (vol6 < 0 ? "negative" : "zero") +
                        " volume; order each tet (a, b, c, d) so that (b-a)x(c-a).(d-a) > 0");
      }
      g.tets = a.tets;
    } else if (kind == ObjectKind::particles) {
      only(a.faces.empty() && a.edges.empty() && a.tets.empty(), "particles take vertices only");
    } else {
      only(surface_kind && a.edges.empty() && a.tets.empty(),
           "a " + std::string(to_string(kind)) + " takes faces, not edges or tets");
      if (a.faces.empty())
        ctx_.fail(path + ".faces", in_node(path), "a " + std::string(to_string(kind)) + " needs faces");
      check_faces(g.v, a.faces, kind, "faces", nullptr, path + ".faces", {path + ".kind"});
      g.faces = a.faces;
    }
    return g;
  }

 public:
  /// The estimate the scene was admitted with, per object (after build()).
  MemoryEstimate memory_estimate() const {
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
    const double have = memory_limit_();
    m.limit_is_max_memory = max_memory_gb_ > 0;
    m.limit_bytes = have > 0 ? have + (m.limit_is_max_memory ? 0.0 : resident_bytes()) : 0.0;
    return m;
  }

 private:
  static std::string cost_list(const std::vector<ObjectCost>& costs) {
    std::string out;
    for (const ObjectCost& c : costs)
      out += (out.empty() ? "" : ", ") + ("'" + printable(c.name) + "' (" + std::string(to_string(c.kind)) + ", " +
                                          count_str(c.counts.v) + " vertices) " + gigabytes(object_bytes(c.counts)));
    return out;
  }
  std::vector<ObjectCost> costs_;
  double max_memory_gb_ = 0;  ///< max_memory: 0 uses what the machine has available
  mutable double available_ = -1;
  const YAML::Node& in_;
  const YAML::Node& cfg_;
  const Context& ctx_;
  fs::path base_;
  const std::map<std::string, MeshArrays>* arrays_;
};

/// A quoted scalar whose closing quote is missing swallows the rest of the file (yaml-cpp accepts
/// it at the end of the input): find the quoted scalars of the tree and check that each closes.
void check_quotes(const YAML::Node& n, const std::string& text, const std::string& label) {
  if (n.IsMap()) {
    for (auto it = n.begin(); it != n.end(); ++it) {
      check_quotes(it->first, text, label);
      check_quotes(it->second, text, label);
    }
  } else if (n.IsSequence()) {
    for (const auto& c : n) check_quotes(c, text, label);
  } else if (n.IsScalar() && !n.Mark().is_null() && n.Mark().pos >= 0) {
    const size_t pos = static_cast<size_t>(n.Mark().pos);
    if (pos >= text.size() || (text[pos] != '"' && text[pos] != '\'')) return;
    const char q = text[pos];
    for (size_t i = pos + 1; i < text.size(); ++i) {
      if (q == '"' && text[i] == '\\')
        ++i;
      else if (text[i] == q) {
        if (q == '\'' && i + 1 < text.size() && text[i + 1] == '\'')
          ++i;  // '' inside single quotes
        else
          return;
      }
    }
    throw ConfigError(label, "", n.Mark().line + 1,
                      std::string("YAML syntax error: unterminated ") + (q == '"' ? "double" : "single") +
                          "-quoted string (the closing " + q + " is missing)");
  }
}

/// Deepest nesting of collections in a scene file: the schema's deepest key path is a few levels;
/// yaml-cpp itself stops at 2000 with "bad file", and walks that deep recurse for every reader.
constexpr int kMaxYamlDepth = 64;
/// Most nodes a scene may expand to, counting each alias as the nodes it stands for: a 4 MiB
/// file holds at most about 2 million nodes written out, so only an alias bomb (nine levels of
/// ten aliases each: 10^9 nodes from 500 bytes) goes beyond, and every reader would walk them all.
constexpr std::uint64_t kMaxYamlNodes = std::uint64_t{1} << 21;

/// Walks the documents of a YAML stream without building nodes. yaml-cpp 0.7's `LoadAll` loops
/// forever (allocating an empty document per turn) on a token its parser cannot start a node with,
/// e.g. a leading ',': each document then starts at the same mark. This counter stops there.
/// It also bounds the nesting depth and the node count with aliases expanded (see above).
class DocumentScan : public YAML::EventHandler {
 public:
  /// Start mark of each document seen, and where its first non-null node starts (if any).
  struct Doc {
    YAML::Mark start;
    bool content = false;
    YAML::Mark first;
  };
  std::vector<Doc> docs;

  explicit DocumentScan(std::string label) : label_(std::move(label)) {}

  void OnDocumentStart(const YAML::Mark& mark) override {
    docs.push_back({mark, false, mark});
    open_.clear();
    expanded_ = 0;
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& m, YAML::anchor_t anchor) override { leaf(m, anchor, 1); }
  void OnAlias(const YAML::Mark& m, YAML::anchor_t anchor) override {
    seen(m);
    // yaml-cpp links an alias inside its own anchor's node into a cycle: every walk of the tree
    // would recurse until the stack overflows.
    for (const Open& o : open_)
      if (o.anchor == anchor)
        throw ConfigError(label_, "", m.line + 1,
                          "an alias refers to the list or map it is inside (opened on line " +
                              std::to_string(o.mark.line + 1) + "): the node would contain itself");
    const auto it = size_of_.find(anchor);
    leaf(m, 0, it == size_of_.end() ? 1 : it->second);
  }
  void OnScalar(const YAML::Mark& m, const std::string&, YAML::anchor_t anchor, const std::string&) override {
    seen(m);
    leaf(m, anchor, 1);
  }
  void OnSequenceStart(const YAML::Mark& m, const std::string&, YAML::anchor_t anchor,
                       YAML::EmitterStyle::value) override {
    seen(m);
    start(m, anchor);
  }
  void OnSequenceEnd() override { end(); }
  void OnMapStart(const YAML::Mark& m, const std::string&, YAML::anchor_t anchor, YAML::EmitterStyle::value) override {
    seen(m);
    start(m, anchor);
  }
  void OnMapEnd() override { end(); }

 private:
  struct Open {
    YAML::anchor_t anchor;
    std::uint64_t size;
    YAML::Mark mark;
  };

  void seen(const YAML::Mark& m) {
    if (!docs.back().content) docs.back().first = m;
    docs.back().content = true;
  }
  void start(const YAML::Mark& m, YAML::anchor_t anchor) {
    if (open_.size() >= static_cast<size_t>(kMaxYamlDepth))
      throw ConfigError(label_, "", m.line + 1,
                        "YAML nesting too deep: more than " + std::to_string(kMaxYamlDepth) +
                            " levels of lists and maps (a scene needs a few)");
    open_.push_back({anchor, 1, m});
    count(m, 1);
  }
  void end() {
    const Open o = open_.back();
    open_.pop_back();
    if (o.anchor) size_of_[o.anchor] = o.size;
    if (!open_.empty()) open_.back().size += o.size;
  }
  /// A node of `size` expanded nodes (1, or an alias's target).
  void leaf(const YAML::Mark& m, YAML::anchor_t anchor, std::uint64_t size) {
    if (anchor) size_of_[anchor] = size;
    if (!open_.empty()) open_.back().size += size;
    count(m, size);
  }
  void count(const YAML::Mark& m, std::uint64_t size) {
    expanded_ += size;
    if (expanded_ > kMaxYamlNodes)
      throw ConfigError(label_, "", m.line + 1,
                        "the scene expands to more than " + std::to_string(kMaxYamlNodes) +
                            " YAML nodes (aliases counted as the nodes they repeat); is this an alias bomb?");
  }

  std::string label_;
  std::vector<Open> open_;
  std::map<YAML::anchor_t, std::uint64_t> size_of_;
  std::uint64_t expanded_ = 0;
};

/// Parses the text of a scene file: printable text, one YAML document, every quoted string closed.
YAML::Node parse_yaml(const std::string& text, const std::string& label, const std::string& what = "scene file") {
  if (text.size() > kMaxSceneFileBytes)
    throw ConfigError(label, "", 0,
                      "the " + what + " has " + std::to_string(text.size()) + " bytes; it is limited to " +
                          std::to_string(kMaxSceneFileBytes >> 20) +
                          " MiB (put meshes in .obj files and reference them with shape.path)");
  // YAML allows no C0 control character but tab, LF and CR; yaml-cpp reads NUL as end of input.
  int line = 1;
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (c == '\n') ++line;
    if ((c < 0x20 && c != '\t' && c != '\n' && c != '\r') || c == 0x7f) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "0x%02x", c);
      throw ConfigError(
          label, "", line,
          "the " + what + " is not text: control byte " + hex + " (YAML allows only tab, newline and carriage return)");
    }
  }
  DocumentScan scan(label);
  try {
    std::istringstream in(text);
    YAML::Parser parser(in);
    while (parser.HandleNextDocument(scan)) {
      const size_t n = scan.docs.size();
      if (n >= 2 && scan.docs[n - 1].start.pos == scan.docs[n - 2].start.pos) {
        const YAML::Mark& m = scan.docs[n - 1].start;
        const size_t pos = m.pos >= 0 ? static_cast<size_t>(m.pos) : 0;
        const std::string token = pos < text.size() ? std::string("'") + text[pos] + "'" : "end of input";
        throw ConfigError(label, "", m.line + 1,
                          "YAML syntax error: unexpected " + token + " at column " + std::to_string(m.column + 1) +
                              " (no YAML node starts with it)");
      }
      if (n >= 2 && scan.docs[n - 1].content)
        throw ConfigError(label, "", scan.docs[n - 1].first.line + 1,
                          "a " + what +
                              " holds one YAML document, but a second one starts here (after '---'); merge "
                              "them or remove it");
    }
  } catch (const YAML::ParserException& e) {
    throw ConfigError(label, "", e.mark.line + 1, "YAML syntax error: " + e.msg);
  }
  if (scan.docs.empty()) return YAML::Node();
  YAML::Node root;
  try {
    root = YAML::Load(text);  // the scan above proved it terminates: one well-formed first document
  } catch (const YAML::ParserException& e) {
    throw ConfigError(label, "", e.mark.line + 1, "YAML syntax error: " + e.msg);
  }
  check_quotes(root, text, label);
  return root;
}

/// Keys that moved into a solver's own section: a clear error instead of "unknown key".
void check_moved_keys(const YAML::Node& root, const Context& ctx) {
  static const std::pair<const char*, const char*> kMoved[] = {
      {"max_projection_iterations", "contact.ccfr.max_iterations"},
      {"redundancy_tolerance", "contact.ccfr.redundancy_tolerance"},
      {"projection_sweeps", "contact.successive_projection.sweeps or contact.post_process.sweeps"},
  };
  const YAML::Node c = root["contact"];
  if (!c || !c.IsMap()) return;  // a missing key is an invalid node: IsMap() would throw
  for (const auto& [old, now] : kMoved)
    if (c[old])
      ctx.fail(std::string("contact.") + old, c[old],
               std::string("this key moved to ") + now + ", the section of the solver it belongs to (docs/config.md)");
}

LoadedScene load(YAML::Node root, const std::string& label, const fs::path& base_dir,
                 const std::vector<std::string>& overrides, const std::string& default_name,
                 const std::map<std::string, MeshArrays>* arrays = nullptr) {
  Context ctx;
  ctx.file = label;
  if (!root.IsDefined() || root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  if (!root.IsMap()) ctx.fail("", root, "a scene file must be a map of keys (scene, time, contact, objects, ...)");
  for (const auto& o : overrides) {
    std::string path;
    try {
      path = schema::apply_override(root, o, scene_schema(), label);
    } catch (const YAML::Exception& e) {
      throw Error("--set '" + o + "': cannot parse the value: " + e.msg);
    }
    ctx.overrides.emplace_back(path, "--set " + o);
  }
  if (!root["scene"]) root["scene"] = default_name;
  check_moved_keys(root, ctx);
  const YAML::Node resolved = schema::resolve(root, scene_schema(), ctx);
  Builder b(root, resolved, ctx, base_dir, arrays);
  LoadedScene out;
  out.scene = b.build();
  out.memory = b.memory_estimate();
  out.resolved_json = schema::to_json(resolved, scene_schema(), 2);
  return out;
}

}  // namespace

LoadedScene load_scene(const fs::path& file, const std::vector<std::string>& overrides) {
  const std::string text = read_user_file(file, "scene file", kMaxSceneFileBytes);
  const YAML::Node root = parse_yaml(text, file.string());
  LoadedScene s = load(root, file.string(), file.parent_path(), overrides, file.stem().string());
  s.source = file;
  return s;
}

YAML::Node parse_bounded_yaml(const std::string& text, const std::string& label, const std::string& what) {
  return parse_yaml(text, label, what);
}

void check_scene_keys(const fs::path& file, const std::vector<std::string>& overrides) {
  const std::string text = read_user_file(file, "scene file", kMaxSceneFileBytes);
  YAML::Node root = parse_yaml(text, file.string());
  Context ctx;
  ctx.file = file.string();
  if (!root.IsDefined() || root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  if (!root.IsMap()) ctx.fail("", root, "a scene file must be a map of keys (scene, time, contact, objects, ...)");
  for (const auto& o : overrides) {
    std::string path;
    try {
      path = schema::apply_override(root, o, scene_schema(), file.string());
    } catch (const YAML::Exception& e) {
      throw Error("--set '" + o + "': cannot parse the value: " + e.msg);
    }
    ctx.overrides.emplace_back(path, "--set " + o);
  }
  if (!root["scene"]) root["scene"] = file.stem().string();
  check_moved_keys(root, ctx);
  schema::resolve(root, scene_schema(), ctx);
}

LoadedScene load_scene_text(const std::string& yaml, const std::string& file_label, const fs::path& base_dir,
                            const std::vector<std::string>& overrides) {
  const YAML::Node root = parse_yaml(yaml, file_label);
  return load(root, file_label, base_dir, overrides, fs::path(file_label).stem().string());
}

LoadedScene load_scene_arrays(const std::string& yaml, const std::string& file_label,
                              const std::map<std::string, MeshArrays>& arrays,
                              const std::vector<std::string>& overrides) {
  const YAML::Node root = parse_yaml(yaml, file_label);
  return load(root, file_label, fs::current_path(), overrides, fs::path(file_label).stem().string(), &arrays);
}

namespace {
template <class R>
void component_table(std::string& o, const R& registry, const std::string& section) {
  o += "\n| " + registry.kind() + " | parameters | description |\n|---|---|---|\n";
  for (const auto& e : registry.entries()) {
    std::string keys;
    for (const auto& p : e.params)
      keys += (keys.empty() ? "`" : ", `") + (section.empty() ? p.key : section + e.name + "." + p.key) + "`";
    o += "| `" + e.name + "` | " + (keys.empty() ? std::string("none") : keys) + " | " + e.description + " |\n";
  }
}
}  // namespace

std::string config_reference_markdown() {
  std::string o = schema::reference_markdown(scene_schema());
  // The registered components, read from the registries like the schema above.
  component_table(o, contact_solvers(), "contact.");
  component_table(o, broad_phases(), "collision.");
  // Projectors are chosen through the contact solver built on them, which exposes their keys.
  component_table(o, projectors(), "");
  return o;
}

}  // namespace ccfr::io
