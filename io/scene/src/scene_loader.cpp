#include "ccfr/io/scene_loader.hpp"

#include <algorithm>
#include <charconv>
#include <map>
#include <optional>
#include <set>

#include "ccfr/collision/broad_phase.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/feasibility/projector.hpp"
#include "ccfr/io/formats.hpp"
#include "ccfr/io/user_file.hpp"
#include "ccfr/solvers/contact_solver.hpp"
#include "ccfr/solvers/material_constraint.hpp"
#include "scene/input.hpp"
#include "scene/memory.hpp"
#include "scene/shapes.hpp"
#include "scene_schema.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;
using schema::Context;

namespace {

using namespace scene;

/// Builds a scene from its resolved configuration by running the readers of io/src/scene/ in
/// order: the global sections, then each object's shape, transform and memory cost (a scene too
/// large is refused before the next object is made), then each object's material, motion,
/// animation, keyframes and pins, and last the masses.
class Builder {
 public:
  Builder(const YAML::Node& input, const YAML::Node& resolved, const Context& ctx, fs::path base_dir,
          const std::map<std::string, MeshArrays>* arrays = nullptr)
      : in_{input, resolved, ctx, std::move(base_dir), arrays} {}

  Scene build() {
    Scene scene;
    auto& p = scene.params;
    budget_.emplace(in_, read_globals(in_, p));
    MemoryBudget& budget = *budget_;
    const YAML::Node objs = in_.cfg["objects"];
    if (!objs || objs.size() == 0) in_.ctx.fail("objects", in_.in, "a scene needs at least one object");

    std::set<std::string> names;
    TopologyBuilder tb;
    std::vector<RawGeometry> geoms;
    Counts total;
    for (size_t i = 0; i < objs.size(); ++i) {
      const YAML::Node o = objs[i];
      const std::string path = "objects[" + std::to_string(i) + "]";
      const std::string name = o["name"].as<std::string>();
      if (const std::string why = name_problem(name, true); !why.empty())
        in_.ctx.fail(path + ".name", in_.in_node(path + ".name"),
                     "object name '" + printable(name) + "' " + why + "; it is written as `o name` in the OBJ frames");
      if (!names.insert(name).second)
        in_.ctx.fail(path + ".name", in_.in_node(path + ".name"), "duplicate object name '" + name + "'");
      const ObjectKind kind = *object_kind_from_string(o["kind"].as<std::string>());
      // Refuse what cannot fit before generating it: counts are predicted from the shape's keys.
      const std::string spath = path + ".shape";
      budget.check_size(total, predict_counts(o["shape"], kind), spath, name, kind);
      RawGeometry g;
      try {
        g = read_shape(in_, o["shape"], kind, path, o["transform"]["scale"].as<double>());
      } catch (const std::invalid_argument& e) {
        in_.ctx.fail(spath, in_.in_node(spath), e.what());
      }
      check_rotation(in_, o["transform"], path + ".transform");
      place(g, o["transform"]);
      check_placed(in_, g.v, path, name);
      // Particles' neighbours are counted up to what the limit could hold, no further.
      const double limit = budget.limit();
      const double grain_cap = limit > 0 ? limit / memory_model::kBytesPerGrainUnit : 1e10;
      const Counts actual =
          MemoryBudget::counts(g, kind, MemoryBudget::reach(p), MemoryBudget::driven_by_pins(o["pins"]), grain_cap);
      budget.check_size(total, actual, spath, name, kind);
      total += actual;
      budget.add(name, kind, actual);
      tb.add_object(name, kind, static_cast<Index>(g.v.size()), g.faces, g.tets, g.lines);
      geoms.push_back(std::move(g));
    }
    budget.charge_contact(total, MemoryBudget::reach(p), p.contact.offset);
    if (log::enabled(log::Level::debug)) {
      std::string detail;
      for (const ObjectCost& c : budget.costs())
        detail += ccfr::format(
            "; '{}' {} v={} sv={} f={} t={} e={} h={:.4g} area={:.4g} rho={:.4g} driven={:.0f} "
            "strand={:.0f} fine={:.0f} grains={:.0f} cross={:.0f} patch={:.0f}: {:.1f} MB",
            printable(c.name), to_string(c.kind), c.counts.v, c.counts.sv, c.counts.f, c.counts.t, c.counts.e,
            c.counts.h, c.counts.area, c.counts.rho, c.counts.driven, c.counts.strand, c.counts.fine, c.counts.grains,
            c.counts.cross, c.counts.patch, object_bytes(c.counts) / 1e6);
      log::debug("{}: estimated memory {:.1f} MB ({} vertices{}), limit {}", in_.ctx.file, estimate_bytes(total) / 1e6,
                 count_str(total.v), detail, gigabytes(budget.limit()));
    }
    // The contact term needs every object: the whole scene is held to the limit once more.
    budget.check_total(total);
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
      op.material = read_material(in_, o["material"].as<std::string>(), path + ".material");
      op.motion = read_motion(o["motion"]);
      check_motion(in_, o["motion"], path + ".motion");
      // Only obstacles follow their object's motion (the simulation moves their vertices alone).
      if (o["motion"] && !info.kinematic())
        in_.ctx.fail(path + ".motion", in_.in_node(path + ".motion"),
                     "only obstacles follow `motion`; a " + std::string(to_string(info.kind)) +
                         " would ignore it: pin vertices and give the pin group a motion (pins[].motion), or "
                         "make the object an obstacle",
                     {path + ".kind"});
      op.initial_velocity = v3(o["velocity"]);
      op.shape = geoms[i].shape;
      if (o["animation"]) read_animation(in_, o, info, st, op, path);
      if (o["keyframes"]) read_keyframes(in_, o, info, st, op, path);
      for (Index v = info.vertex_begin; v < info.vertex_end; ++v) st.v[v] = op.initial_velocity;
      read_pins(in_, o["pins"], info, st, op, path);
    }
    st.rest = st.x;
    st.x_prev = st.x;
    compute_masses(in_, scene);
    return scene;
  }

  /// The estimate the scene was admitted with, per object (after build()).
  MemoryEstimate memory_estimate() const { return budget_->estimate(); }

 private:
  Input in_;
  std::optional<MemoryBudget> budget_;  ///< made once max_memory is read
};

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

/// The deepest node of `root` along `key_path` ("contact.dat.query_radius", "objects[2].shape"):
/// the key itself when written, else the closest section that is (a default's key has no line).
YAML::Node node_at(const YAML::Node& root, const std::string& key_path) {
  YAML::Node cur;
  cur.reset(root);
  std::string seg;
  const auto descend = [&] {
    if (seg.empty()) return;
    YAML::Node next;
    if (cur.IsMap() && cur[seg]) {
      next = cur[seg];
    } else if (size_t i = 0; cur.IsSequence() &&
                             std::from_chars(seg.data(), seg.data() + seg.size(), i).ptr == seg.data() + seg.size() &&
                             i < cur.size()) {
      next = cur[i];
    } else {
      seg = "\x01";  // not written: stay at the closest section
      return;
    }
    cur.reset(next);
    seg.clear();
  };
  for (const char ch : key_path) {
    if (seg == "\x01") break;
    if (ch == '.' || ch == '[' || ch == ']')
      descend();
    else
      seg += ch;
  }
  if (seg != "\x01") descend();
  return cur;
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
  // The tree as written (after the overrides): its marks are the file's lines.
  out.fail_at = [root, ctx](const std::string& key_path, const std::string& message) {
    YAML::Node at = node_at(root, key_path);
    ctx.fail(key_path, at, message);
  };
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

void rethrow_located(const LoadedScene& scene, const Error& e) {
  const std::string what = e.what();
  const size_t colon = what.find(": ");
  const std::string key = what.substr(0, colon);
  // A key path: section names and [indices], a top-level section of the schema first.
  const bool is_key = colon != std::string::npos && !key.empty() && scene.fail_at &&
                      key.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_.[]") == std::string::npos &&
                      std::ranges::any_of(scene_schema()->fields, [&](const schema::Field& f) {
                        return f.key == key.substr(0, key.find_first_of(".["));
                      });
  if (is_key) scene.fail_at(key, what.substr(colon + 2));
  throw;
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
    for (const auto& p : e.params) {
      const std::string key = section.empty()           ? p.key
                              : !p.material_key.empty() ? section + p.material_key
                                                        : section + e.name + "." + p.key;
      keys += (keys.empty() ? "`" : ", `") + key + "`";
    }
    o += "| `" + e.name + "` | " + (keys.empty() ? std::string("none") : keys) + " | " + e.description + " |\n";
  }
}
}  // namespace

std::string config_reference_markdown() {
  std::string o = schema::reference_markdown(scene_schema());
  // The registered components, read from the registries like the schema above.
  component_table(o, contact_solvers(), "contact.");
  component_table(o, broad_phases(), "collision.");
  component_table(o, frame_writers(), "output.");
  component_table(o, material_constraints(), "materials.<material>.");
  // Projectors are chosen through the contact solver built on them, which exposes their keys.
  component_table(o, projectors(), "");
  return o;
}

namespace {

/// The schema node at `path` (a list stands for its item; at a variant, the next segment names
/// the variant); null if there is none.
const schema::Node* schema_node(const std::vector<std::string>& path) {
  const schema::Node* n = scene_schema().get();
  for (const std::string& seg : path) {
    if (n && (n->kind == schema::Kind::list || n->kind == schema::Kind::dict)) n = n->item.get();
    const schema::Node* next = nullptr;
    if (n && n->kind == schema::Kind::variant) {
      for (const auto& [name, v] : n->variants)
        if (name == seg) next = v.get();
    } else if (n) {
      for (const auto& f : n->fields)
        if (f.key == seg) next = f.node.get();
    }
    n = next;
  }
  return n;
}

/// A key read through a choice table: its path in the schema and the table's strings, plus
/// whether the table maps each string to a different value and each value to one string.
struct TableKey {
  std::string key;
  std::vector<std::string> path;
  std::vector<std::string> names;
  bool one_to_one;
};

template <class E>
TableKey table_key(std::string key, std::vector<std::string> path, const ChoiceTable<E>& t) {
  bool one_to_one = true;
  for (size_t i = 0; i < t.entries.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (t.entries[i].first == t.entries[j].first || t.entries[i].second == t.entries[j].second) one_to_one = false;
  return {std::move(key), std::move(path), t.names(), one_to_one};
}

std::vector<TableKey> table_keys() {
  return {table_key("time.continuation", {"time", "continuation"}, continuation_choices()),
          table_key("contact.on_violation", {"contact", "on_violation"}, violation_choices()),
          table_key("debug.audit", {"debug", "audit"}, audit_choices()),
          table_key("objects.shape.layout", {"objects", "shape", "strands", "layout"}, strand_layout_choices())};
}

}  // namespace

std::vector<std::pair<std::string, std::vector<std::string>>> table_choices() {
  std::vector<std::pair<std::string, std::vector<std::string>>> out;
  for (const TableKey& k : table_keys()) {
    const schema::Node* n = schema_node(k.path);
    out.emplace_back(k.key, n && n->kind == schema::Kind::choice ? n->choices() : std::vector<std::string>{});
  }
  return out;
}

std::vector<std::string> reader_schema_mismatches() {
  std::vector<std::string> out;
  const auto joined = [](const std::vector<std::string>& v) {
    std::string s;
    for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
    return "[" + s + "]";
  };
  for (const TableKey& k : table_keys()) {
    const schema::Node* n = schema_node(k.path);
    if (!n || n->kind != schema::Kind::choice)
      out.push_back(k.key + ": no choice in the schema");
    else if (n->choices() != k.names)
      out.push_back(k.key + ": the schema offers " + joined(n->choices()) + ", the table maps " + joined(k.names));
    if (!k.one_to_one) out.push_back(k.key + ": the table repeats a string or a value");
  }
  const schema::Node* shape = schema_node({"objects", "shape"});
  std::vector<std::string> types;
  if (shape)
    for (const auto& [name, v] : shape->variants) types.push_back(name);
  std::vector<std::string> readers = generator_types();
  readers.push_back("mesh");  // read by mesh_sources.cpp
  for (const auto& t : types)
    if (std::find(readers.begin(), readers.end(), t) == readers.end())
      out.push_back("shape type '" + t + "' has no reader");
  for (const auto& r : readers)
    if (std::find(types.begin(), types.end(), r) == types.end())
      out.push_back("shape reader '" + r + "' is no type of the schema's objects.shape");
  return out;
}

}  // namespace ccfr::io
