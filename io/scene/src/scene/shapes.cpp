// objects[i].shape: one reader per geometry source (the variants of the schema's `shape`), each
// with its keys (declared here, next to the code that reads them), the kinds it can make, the element counts it will
// make (read from its keys, so that a scene too large for memory is refused before it is generated) and the generator
// call.
#include <algorithm>
#include <string_view>

#include "../scene_schema.hpp"
#include "ccfr/geometry/generators.hpp"
#include "memory.hpp"
#include "shapes.hpp"

namespace ccfr::io::scene {

namespace {

using namespace schema;
Range pos() { return Range::positive_up_to(kMaxLength); }
Range nonneg() { return Range::up_to(kMaxLength); }
Range one() { return Range::at_least(1); }

double num(const YAML::Node& n) { return n.as<double>(); }

/// Moves a generated triangle mesh into `g`.
void take(RawGeometry& g, gen::TriMesh m) {
  g.v = std::move(m.v);
  g.faces = std::move(m.f);
}

/// A generator source: its keys (the schema's variant of `shape`), the kinds it can make (`use` names them when it
/// cannot), its element counts predicted from its keys (none: unknown until made), and what it makes.
struct Generator {
  std::string_view type;
  schema::NodePtr (*keys)();  ///< its keys: type, default, range and doc
  bool (*can_make)(ObjectKind);
  const char* use;
  void (*predict)(const YAML::Node& s, Counts& c);
  void (*make)(const Input& in, const YAML::Node& s, ObjectKind kind, const std::string& path, RawGeometry& g);
};

bool strand_only(ObjectKind k) { return k == ObjectKind::strand; }
bool particles_only(ObjectKind k) { return k == ObjectKind::particles; }
bool tet_solid_only(ObjectKind k) { return k == ObjectKind::tet_solid; }

const Generator kGenerators[] = {
    {"grid",
     [] {
       return map("rectangular cloth in the x-z plane, normal +y",
                  {{"size", vec2(std::nullopt, "side lengths [x, z] (m)", pos())},
                   {"resolution", ivec2(std::nullopt, "cells per side [x, z]", one())}});
     },
     surface_kind, "use kind cloth, shell, obstacle or rigid",
     [](const YAML::Node& s, Counts& c) {
       const double rx = num(s["resolution"][0]), rz = num(s["resolution"][1]);
       c.v = (rx + 1) * (rz + 1), c.f = 2 * rx * rz;
     },
     [](const Input&, const YAML::Node& s, ObjectKind kind, const std::string&, RawGeometry& g) {
       take(g, gen::grid(s["size"][0].as<double>(), s["size"][1].as<double>(), s["resolution"][0].as<Index>(),
                         s["resolution"][1].as<Index>()));
       // A flat obstacle grid is also an analytic plane (normal +y) for the SDF pass.
       if (kind == ObjectKind::obstacle) g.shape.type = AnalyticShape::Type::plane;
     }},
    {"strands",
     [] {
       return map("straight or curly strands hanging along -y",
                  {{"count", integer(1, "number of strands", one())},
                   {"vertices", integer(20, "vertices per strand", Range::at_least(2))},
                   {"length", number(1.0, "strand length along -y (m)", pos())},
                   {"spread", number(0.0, "roots spread on a square of this side (m)", nonneg())},
                   {"coil_radius", number(0.0, "helix radius; 0 gives straight strands (m)", nonneg())},
                   {"turns", number(0.0, "helix turns per strand", nonneg())},
                   {"layout", choice(
                                  strand_layout_choices().name(false), [] { return strand_layout_choices().names(); },
                                  "roots on a square grid, or on one row along x")}});
     },
     strand_only, "use kind strand",
     [](const YAML::Node& s, Counts& c) {
       c.v = num(s["count"]) * num(s["vertices"]), c.e = num(s["count"]) * (num(s["vertices"]) - 1);
     },
     [](const Input&, const YAML::Node& s, ObjectKind, const std::string&, RawGeometry& g) {
       auto ps = gen::curly_strands(s["count"].as<Index>(), s["vertices"].as<Index>(), s["length"].as<double>(),
                                    s["spread"].as<double>(), s["coil_radius"].as<double>(), s["turns"].as<double>(),
                                    strand_layout_choices().value(s["layout"].as<std::string>()));
       g.v = std::move(ps.v);
       g.lines = std::move(ps.lines);
     }},
    {"particles",
     [] {
       return map("a lattice block of free particles",
                  {{"counts", ivec3(std::nullopt, "particles per axis [x, y, z]", one())},
                   {"spacing", number(0.01, "lattice spacing (m)", pos())}});
     },
     particles_only, "use kind particles",
     [](const YAML::Node& s, Counts& c) { c.v = num(s["counts"][0]) * num(s["counts"][1]) * num(s["counts"][2]); },
     [](const Input&, const YAML::Node& s, ObjectKind, const std::string&, RawGeometry& g) {
       const auto c = s["counts"];
       g.v = gen::particle_block(c[0].as<Index>(), c[1].as<Index>(), c[2].as<Index>(), s["spacing"].as<double>());
     }},
    {"tet_box",
     [] {
       return map("a tetrahedralised box (6 tets per cell)",
                  {{"size", required_vec3("box size [x, y, z] (m)", pos())},
                   {"resolution", ivec3(std::array<long long, 3>{2, 2, 2}, "cells per axis", one())}});
     },
     tet_solid_only, "use kind tet_solid",
     [](const YAML::Node& s, Counts& c) {
       const double x = num(s["resolution"][0]), y = num(s["resolution"][1]), z = num(s["resolution"][2]);
       c.v = (x + 1) * (y + 1) * (z + 1), c.t = 6 * x * y * z, c.f = 4 * (x * y + y * z + z * x);
     },
     [](const Input&, const YAML::Node& s, ObjectKind, const std::string&, RawGeometry& g) {
       const auto r = s["resolution"];
       auto m = gen::tet_box(v3(s["size"]), Vec3i(r[0].as<Index>(), r[1].as<Index>(), r[2].as<Index>()));
       g.v = std::move(m.v);
       g.tets = std::move(m.t);
     }},
    {"sphere",
     [] {
       return map("icosphere", {{"radius", number(0.5, "radius (m)", pos())},
                                {"subdivisions", integer(3, "icosahedron subdivisions", Range{0, 7})}});
     },
     surface_kind, "use kind obstacle, rigid, shell or cloth", nullptr,
     [](const Input&, const YAML::Node& s, ObjectKind, const std::string&, RawGeometry& g) {
       take(g, gen::sphere(s["radius"].as<double>(), s["subdivisions"].as<int>()));
       g.shape.type = AnalyticShape::Type::sphere;
       g.shape.radius = s["radius"].as<double>();
     }},
    {"cylinder",
     [] {
       return map("cylinder along y", {{"radius", number(0.5, "radius (m)", pos())},
                                       {"height", number(1.0, "height (m)", pos())},
                                       {"segments", integer(32, "segments around", Range::at_least(3))},
                                       {"capped", boolean(true, "close the ends")}});
     },
     surface_kind, "use kind obstacle, rigid, shell or cloth",
     [](const YAML::Node& s, Counts& c) { c.v = 2 * num(s["segments"]) + 2, c.f = 4 * num(s["segments"]); },
     [](const Input&, const YAML::Node& s, ObjectKind, const std::string&, RawGeometry& g) {
       take(g, gen::cylinder(s["radius"].as<double>(), s["height"].as<double>(), s["segments"].as<Index>(),
                             s["capped"].as<bool>()));
       g.shape.type = AnalyticShape::Type::cylinder;
       g.shape.radius = s["radius"].as<double>();
       g.shape.half_height = 0.5 * s["height"].as<double>();
     }},
    {"box",
     [] {
       return map("closed box, outward normals", {{"size", required_vec3("size [x, y, z] (m)", pos())}});
     },
     surface_kind, "use kind obstacle, rigid, shell or cloth", nullptr,
     [](const Input& in, const YAML::Node& s, ObjectKind, const std::string& path, RawGeometry& g) {
       const Vec3 size = v3(s["size"]);
       if ((size.array() <= 0).any())
         in.ctx.fail(path + ".shape.size", in.in_node(path + ".shape.size"), "box sizes must be > 0");
       take(g, gen::box(size));
       g.shape.type = AnalyticShape::Type::box;
       g.shape.half_extent = 0.5 * size;
     }},
    {"open_box",
     [] {
       return map("floor and four walls, open at the top, normals inward",
                  {{"size", required_vec3("size [x, y, z] (m)", pos())}});
     },
     surface_kind, "use kind obstacle, rigid, shell or cloth", nullptr,
     [](const Input& in, const YAML::Node& s, ObjectKind, const std::string& path, RawGeometry& g) {
       const Vec3 size = v3(s["size"]);
       if ((size.array() <= 0).any())
         in.ctx.fail(path + ".shape.size", in.in_node(path + ".shape.size"), "box sizes must be > 0");
       take(g, gen::open_box(size));
     }},
    {"plane",
     [] {
       return map("square plane in the x-z plane, normal +y", {{"size", number(10.0, "side length (m)", pos())},
                                                               {"resolution", integer(1, "cells per side", one())}});
     },
     surface_kind, "use kind obstacle, shell or cloth",
     [](const YAML::Node& s, Counts& c) {
       const double r = num(s["resolution"]);
       c.v = (r + 1) * (r + 1), c.f = 2 * r * r;
     },
     [](const Input&, const YAML::Node& s, ObjectKind, const std::string&, RawGeometry& g) {
       take(g, gen::plane(s["size"].as<double>(), s["resolution"].as<Index>()));
       g.shape.type = AnalyticShape::Type::plane;
     }},
    {"octopus",
     [] {
       return map(
           "procedural octopus-like tet solid: a cubic body with tentacles (the paper's octopus mesh is "
           "not published)",
           {{"cell", number(0.05, "edge of the voxel cells (m)", pos())},
            {"body", integer(4, "body cells per axis", Range::at_least(2))},
            {"legs", integer(8, "number of tentacles", nonneg())},
            {"leg_length", integer(8, "cells per tentacle", nonneg())}});
     },
     tet_solid_only, "use kind tet_solid",
     [](const YAML::Node& s, Counts& c) {
       const double b = num(s["body"]), cells = b * b * b + 2 * num(s["legs"]) * num(s["leg_length"]);
       c.v = 8 * cells, c.t = 6 * cells, c.f = 12 * cells;
     },
     [](const Input&, const YAML::Node& s, ObjectKind, const std::string&, RawGeometry& g) {
       auto m = gen::octopus(s["cell"].as<double>(), s["body"].as<Index>(), s["legs"].as<Index>(),
                             s["leg_length"].as<Index>());
       g.v = std::move(m.v);
       g.tets = std::move(m.t);
     }},
    {"comb",
     [] {
       return map("procedural comb: a spine box with teeth hanging below (the paper's comb mesh is not published)",
                  {{"length", number(1.0, "spine length along x (m)", pos())},
                   {"width", number(0.05, "thickness along z (m)", pos())},
                   {"spine_height", number(0.1, "spine height (m)", pos())},
                   {"teeth", integer(12, "number of teeth", one())},
                   {"tooth_length", number(0.4, "tooth length below the spine (m)", pos())},
                   {"tooth_width", number(0.02, "tooth width along x (m)", pos())}});
     },
     surface_kind, "use kind obstacle, rigid, shell or cloth",
     [](const YAML::Node& s, Counts& c) { c.v = 8 * (num(s["teeth"]) + 1), c.f = 12 * (num(s["teeth"]) + 1); },
     [](const Input&, const YAML::Node& s, ObjectKind, const std::string&, RawGeometry& g) {
       take(g, gen::comb(s["length"].as<double>(), s["width"].as<double>(), s["spine_height"].as<double>(),
                         s["teeth"].as<Index>(), s["tooth_length"].as<double>(), s["tooth_width"].as<double>()));
     }},
};

const Generator* find_generator(const std::string& type) {
  for (const Generator& gen : kGenerators)
    if (gen.type == type) return &gen;
  return nullptr;
}

}  // namespace

bool surface_kind(ObjectKind kind) {
  return kind == ObjectKind::cloth || kind == ObjectKind::shell || kind == ObjectKind::obstacle ||
         kind == ObjectKind::rigid;
}

std::vector<std::pair<std::string, schema::NodePtr>> shape_variants() {
  std::vector<std::pair<std::string, schema::NodePtr>> out;
  for (const Generator& gen : kGenerators) out.emplace_back(std::string(gen.type), gen.keys());
  out.emplace_back("mesh", mesh_schema());  // Mesh inputs (docs/interop.md).
  return out;
}

std::vector<std::string> generator_types() {
  std::vector<std::string> out;
  for (const Generator& gen : kGenerators) out.emplace_back(gen.type);
  return out;
}

Counts predict_counts(const YAML::Node& s, ObjectKind kind) {
  Counts c;
  const Generator* gen = find_generator(s["type"].as<std::string>());
  if (gen && gen->predict) gen->predict(s, c);  // a mesh: unknown until read
  return as_kind(c, kind);
}

RawGeometry read_shape(const Input& in, const YAML::Node& s, ObjectKind kind, const std::string& path, double scale) {
  const std::string type = s["type"].as<std::string>();
  const std::string tpath = path + ".shape.type";
  auto require = [&](bool ok, const std::string& what) {
    if (!ok)
      in.ctx.fail(tpath, in.in_node(tpath),
                  "shape '" + type + "' cannot make a " + std::string(to_string(kind)) + " object; " + what,
                  {path + ".kind"});
  };
  RawGeometry g;
  if (type == "mesh" && in.arrays && in.arrays->count(s["path"].as<std::string>())) {
    g = read_mesh_arrays(in, in.arrays->at(s["path"].as<std::string>()), kind, path,
                         [&](bool ok, const std::string& what) {
                           if (!ok)
                             in.ctx.fail(path + ".kind", in.in_node(path + ".kind"),
                                         "arrays cannot make a " + std::string(to_string(kind)) + " object: " + what);
                         });
    if (kind != ObjectKind::obstacle) g.shape.type = AnalyticShape::Type::none;
    return g;
  }
  if (type == "mesh") {
    g = read_mesh_file(in, s, kind, path, scale, require);
  } else if (const Generator* gen = find_generator(type)) {
    require(gen->can_make(kind), gen->use);
    gen->make(in, s, kind, path, g);
    if (!g.faces.empty()) check_faces(in, g.v, g.faces, kind, "shape '" + type + "'", nullptr, tpath, {path + ".kind"});
  }
  if (kind != ObjectKind::obstacle) g.shape.type = AnalyticShape::Type::none;  // only obstacles collide analytically
  return g;
}

}  // namespace ccfr::io::scene
