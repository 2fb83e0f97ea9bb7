#include "ccfr/io/scene_loader.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <numbers>
#include <set>
#include <sstream>

#include "ccfr/core/error.hpp"
#include "ccfr/geometry/generators.hpp"
#include "ccfr/io/obj.hpp"
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

class Builder {
 public:
  Builder(const YAML::Node& input, const YAML::Node& resolved, const Context& ctx, fs::path base_dir)
      : in_(input), cfg_(resolved), ctx_(ctx), base_(std::move(base_dir)) {}

  Scene build() {
    Scene scene;
    auto& p = scene.params;
    read_global(p);
    const YAML::Node objs = cfg_["objects"];
    if (!objs || objs.size() == 0) ctx_.fail("objects", in_, "a scene needs at least one object");

    std::set<std::string> names;
    TopologyBuilder tb;
    std::vector<RawGeometry> geoms;
    for (size_t i = 0; i < objs.size(); ++i) {
      const YAML::Node o = objs[i];
      const std::string path = "objects[" + std::to_string(i) + "]";
      const std::string name = o["name"].as<std::string>();
      if (!names.insert(name).second)
        ctx_.fail(path + ".name", in_node(path + ".name"), "duplicate object name '" + name + "'");
      const ObjectKind kind = *object_kind_from_string(o["kind"].as<std::string>());
      RawGeometry g = make_geometry(o["shape"], kind, path);
      place(g, o["transform"]);
      tb.add_object(name, kind, static_cast<Index>(g.v.size()), g.faces, g.tets, g.lines);
      geoms.push_back(std::move(g));
    }
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
      op.initial_velocity = v3(o["velocity"]);
      op.shape = geoms[i].shape;
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

  void read_global(SimulationParams& p) {
    p.scene_name = cfg_["scene"] ? cfg_["scene"].as<std::string>() : std::string("scene");
    const auto t = cfg_["time"];
    p.time.fps = t["fps"].as<double>();
    p.time.frames = t["frames"].as<int>();
    p.time.substeps = t["substeps"].as<int>();
    p.time.iterations = t["iterations"].as<int>();
    p.time.xpbd_sweeps = t["xpbd_sweeps"].as<int>();
    p.time.gravity = v3(t["gravity"]);
    p.time.damping = t["damping"].as<double>();
    p.time.advance_tolerance = t["advance_tolerance"].as<double>();
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
    p.contact.max_projection_iterations = c["max_projection_iterations"].as<int>();
    p.contact.redundancy_tolerance = c["redundancy_tolerance"].as<double>();
    p.contact.projection_sweeps = c["projection_sweeps"].as<int>();
    p.contact.analytic_obstacles = c["analytic_obstacles"].as<bool>();
    const std::string policy = c["on_violation"].as<std::string>();
    p.contact.on_violation = policy == "error"  ? ViolationPolicy::error
                             : policy == "warn" ? ViolationPolicy::warn
                                                : ViolationPolicy::automatic;
    p.collision.broad_phase = cfg_["collision"]["broad_phase"].as<std::string>();
    const auto d = cfg_["debug"];
    const std::string audit = d["audit"].as<std::string>();
    p.debug.audit = audit == "every_frame"     ? AuditMode::every_frame
                    : audit == "every_substep" ? AuditMode::every_substep
                                               : AuditMode::off;
    p.debug.audit_tolerance = d["audit_tolerance"].as<double>();
    p.output.frames = cfg_["output"]["frames"].as<bool>();
    p.output.every = cfg_["output"]["every"].as<int>();
    if (p.contact.friction_kinetic > p.contact.friction_static && p.contact.friction_static > 0)
      ctx_.fail("contact.friction.kinetic", in_node("contact.friction.kinetic"),
                "kinetic friction must not exceed static friction");
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

  RawGeometry make_geometry(const YAML::Node& s, ObjectKind kind, const std::string& path) {
    const std::string type = s["type"].as<std::string>();
    const std::string tpath = path + ".shape.type";
    auto require = [&](bool ok, const std::string& what) {
      if (!ok)
        ctx_.fail(tpath, in_node(tpath),
                  "shape '" + type + "' cannot make a " + std::string(to_string(kind)) + " object; " + what);
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
    } else if (type == "mesh") {
      const std::string ppath = path + ".shape.path";
      fs::path file = s["path"].as<std::string>();
      if (file.is_relative()) file = base_ / file;
      if (!fs::exists(file)) ctx_.fail(ppath, in_node(ppath), "mesh file '" + file.string() + "' does not exist");
      ObjMesh m;
      try {
        m = read_obj_mesh(file);
      } catch (const Error& e) {
        ctx_.fail(ppath, in_node(ppath), std::string("cannot read mesh: ") + e.what());
      }
      g.v = std::move(m.v);
      if (kind == ObjectKind::strand) {
        if (m.lines.empty())
          ctx_.fail(ppath, in_node(ppath), "a strand mesh needs `l` lines; '" + file.string() + "' has none");
        g.lines = std::move(m.lines);
      } else {
        require(surface_kind, "meshes make cloth, shell, obstacle, rigid or strand objects");
        if (m.f.empty()) ctx_.fail(ppath, in_node(ppath), "mesh '" + file.string() + "' has no faces");
        g.faces = std::move(m.f);
      }
    }
    if (kind != ObjectKind::obstacle) g.shape.type = AnalyticShape::Type::none;  // only obstacles collide analytically
    return g;
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

  void read_pins(const YAML::Node& pins, const ObjectInfo& info, SimState& st, ObjectParams& op,
                 const std::string& path) {
    if (!pins) return;
    for (size_t k = 0; k < pins.size(); ++k) {
      const YAML::Node pn = pins[k];
      const std::string pp = path + ".pins[" + std::to_string(k) + "]";
      PinGroup grp;
      grp.motion = read_motion(pn["motion"]);
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
          // Closed surface: enclosed volume by the divergence theorem, spread evenly over vertices.
          double vol = 0.0;
          for (Index f = o.face_begin; f < o.face_end; ++f) {
            const auto& t = topo.faces[f];
            vol += st.x[t[0]].dot(st.x[t[1]].cross(st.x[t[2]])) / 6.0;
          }
          for (Index v = o.vertex_begin; v < o.vertex_end; ++v) st.mass[v] = rho * std::abs(vol) / o.num_vertices();
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

  const YAML::Node& in_;
  const YAML::Node& cfg_;
  const Context& ctx_;
  fs::path base_;
};

LoadedScene load(YAML::Node root, const std::string& label, const fs::path& base_dir,
                 const std::vector<std::string>& overrides, const std::string& default_name) {
  Context ctx;
  ctx.file = label;
  if (!root.IsDefined() || root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  if (!root.IsMap()) ctx.fail("", root, "a scene file must be a map of keys (scene, time, contact, objects, ...)");
  for (const auto& o : overrides) {
    std::string path;
    try {
      path = schema::apply_override(root, o);
    } catch (const YAML::Exception& e) {
      throw Error("--set '" + o + "': cannot parse the value: " + e.msg);
    }
    ctx.overrides.emplace_back(path, "--set " + o);
  }
  if (!root["scene"]) root["scene"] = default_name;
  const YAML::Node resolved = schema::resolve(root, scene_schema(), ctx);
  Builder b(root, resolved, ctx, base_dir);
  LoadedScene out;
  out.scene = b.build();
  out.resolved_json = schema::to_json(resolved, scene_schema(), 2);
  return out;
}

}  // namespace

LoadedScene load_scene(const fs::path& file, const std::vector<std::string>& overrides) {
  if (!fs::exists(file)) throw Error("scene file '" + file.string() + "' does not exist");
  if (fs::is_directory(file)) throw Error("'" + file.string() + "' is a directory, not a scene file");
  YAML::Node root;
  try {
    root = YAML::LoadFile(file.string());
  } catch (const YAML::ParserException& e) {
    throw ConfigError(file.string(), "", e.mark.line + 1, "YAML syntax error: " + e.msg);
  } catch (const YAML::BadFile&) {
    throw Error("cannot read scene file '" + file.string() + "'");
  }
  LoadedScene s = load(root, file.string(), file.parent_path(), overrides, file.stem().string());
  s.source = file;
  return s;
}

LoadedScene load_scene_text(const std::string& yaml, const std::string& file_label, const fs::path& base_dir,
                            const std::vector<std::string>& overrides) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::ParserException& e) {
    throw ConfigError(file_label, "", e.mark.line + 1, "YAML syntax error: " + e.msg);
  }
  return load(root, file_label, base_dir, overrides, fs::path(file_label).stem().string());
}

std::string config_reference_markdown() { return schema::reference_markdown(scene_schema()); }

}  // namespace ccfr::io
