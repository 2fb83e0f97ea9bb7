// The readers of the global sections (time, contact, collision, debug, output) and of materials:
// each fills its parameter struct through the section bound in scene_schema.cpp, then checks what
// spans keys (a component's own section, friction's order, an empty format list).
#include <algorithm>
#include <limits>
#include <string>

#include "../scene_schema.hpp"
#include "ccfr/collision/broad_phase.hpp"
#include "ccfr/io/formats.hpp"
#include "ccfr/io/user_file.hpp"
#include "ccfr/solvers/contact_solver.hpp"
#include "ccfr/solvers/material_constraint.hpp"
#include "input.hpp"

namespace ccfr::io::scene {

namespace {

/// The values of `specs` from `node`, a section the schema resolved (every key present); a spec
/// naming a material key reads that key.
ParamValues read_params(std::span<const ParamSpec> specs, const YAML::Node& node) {
  ParamValues v;
  for (const auto& spec : specs) {
    const YAML::Node n = node[spec.material_key.empty() ? spec.key : spec.material_key];
    switch (spec.type) {
      case ParamType::boolean:
        v.set(spec.key, n.as<bool>());
        break;
      case ParamType::integer:
        v.set(spec.key, n.as<long long>());
        break;
      case ParamType::number:
        v.set(spec.key, n.as<double>());
        break;
      case ParamType::choice:
        v.set(spec.key, n.as<std::string>());
        break;
    }
  }
  return v;
}

/// The parameters of the component that `section.selector` names, from its section
/// `section.<name>.*`. A section set in the input for another component is an error: its values
/// would silently do nothing.
template <class R>
ParamValues component_params(const Input& in, const R& registry, const std::string& section,
                             const std::string& selector) {
  const std::string chosen = in.cfg[section][selector].template as<std::string>();
  const YAML::Node given = in.in[section];
  for (const auto& e : registry.entries()) {
    if (e.name == chosen || e.params.empty() || !given || !given.IsMap() || !given[e.name]) continue;
    const std::string path = section + "." + e.name;
    in.ctx.fail(path, in.in_node(path),
                "parameters of " + registry.kind() + " '" + e.name + "' are set, but " + section + "." + selector +
                    " is '" + chosen + "'; remove the section or set " + section + "." + selector + ": " + e.name,
                {section + "." + selector});
  }
  const auto* entry = registry.find(chosen);
  if (!entry) return {};  // the schema's choice already rejected unknown names
  return read_params(entry->params, in.cfg[section][chosen]);
}

void read_contact(const Input& in, ContactParams& c) {
  contact_section().read(c, in.cfg["contact"]);
  c.solver_params = component_params(in, contact_solvers(), "contact", "solver");
}

void read_collision(const Input& in, DetectionParams& d) {
  collision_section().read(d, in.cfg["collision"]);
  d.broad_phase_params = component_params(in, broad_phases(), "collision", "broad_phase");
}

void read_output(const Input& in, OutputParams& o) {
  output_section().read(o, in.cfg["output"]);
  if (const YAML::Node fm = in.cfg["output"]["formats"]) {
    for (size_t k = 0; k < fm.size(); ++k) o.formats.push_back(fm[k].as<std::string>());
    if (o.formats.empty()) {
      std::string names;  // the schema's choices
      for (const auto& n : frame_writer_names()) names += (names.empty() ? "" : ", ") + n;
      in.ctx.fail("output.formats", in.in_node("output.formats"), "list at least one format (" + names + ")");
    }
  }
  // A writer's section (output.<format>.*) for a format the run does not write would do nothing.
  // Its values reach the writer through the resolved configuration (RunWriter).
  const std::vector<std::string> chosen = o.formats.empty() ? std::vector<std::string>{"obj"} : o.formats;
  const YAML::Node given = in.in["output"];
  for (const auto& e : frame_writers().entries()) {
    if (e.params.empty() || !given || !given.IsMap() || !given[e.name]) continue;
    if (std::find(chosen.begin(), chosen.end(), e.name) != chosen.end()) continue;
    const std::string path = "output." + e.name;
    in.ctx.fail(path, in.in_node(path),
                "parameters of output format '" + e.name + "' are set, but output.formats does not list it; " +
                    "remove the section or add " + e.name + " to output.formats",
                {"output.formats"});
  }
}

}  // namespace

namespace {

// Cross-key bounds of the time section: a maximum below the nominal count, and the outer iterations
// a frame may run (substeps x subdivision x iteration bound), which stats.csv counts in int.
void check_time_counts(const Input& in, const TimeParams& t) {
  if (t.max_iterations > 0 && t.max_iterations < t.iterations)
    in.ctx.fail("time.max_iterations", in.in_node("time.max_iterations"),
                "time.max_iterations (" + std::to_string(t.max_iterations) + ") is below time.iterations (" +
                    std::to_string(t.iterations) + "); raise it to at least " + std::to_string(t.iterations) +
                    ", or 0 for 4 x iterations",
                {"time.iterations"});
  const long long per_frame = static_cast<long long>(t.substeps) * t.max_subdivision * t.iteration_bound();
  if (per_frame > std::numeric_limits<int>::max())
    in.ctx.fail("time.substeps", in.in_node("time.substeps"),
                "time.substeps (" + std::to_string(t.substeps) + ") x time.max_subdivision (" +
                    std::to_string(t.max_subdivision) + ") x the iteration bound (" +
                    std::to_string(t.iteration_bound()) + ") allows " + std::to_string(per_frame) +
                    " outer iterations per frame, more than 2147483647; lower one of them",
                {"time.max_subdivision", "time.iterations", "time.max_iterations"});
}

}  // namespace

double read_globals(const Input& in, SimulationParams& p) {
  // load() names an unnamed scene after its file; `scene: ~` (resolved away) is "scene"
  p.scene_name = in.cfg["scene"] ? in.cfg["scene"].as<std::string>() : std::string("scene");
  const double max_memory_gb = in.cfg["max_memory"].as<double>();
  if (const std::string why = name_problem(p.scene_name, false); !why.empty())
    in.ctx.fail("scene", in.in_node("scene"), "scene name '" + printable(p.scene_name) + "' " + why);
  time_section().read(p.time, in.cfg["time"]);
  check_time_counts(in, p.time);
  read_contact(in, p.contact);
  read_collision(in, p.collision);
  debug_section().read(p.debug, in.cfg["debug"]);
  read_output(in, p.output);
  // Checked last, as it always was: with several mistakes the first one reported stays the same.
  if (p.contact.friction_kinetic > p.contact.friction_static && p.contact.friction_static > 0)
    in.ctx.fail("contact.friction.kinetic", in.in_node("contact.friction.kinetic"),
                "kinetic friction must not exceed static friction", {"contact.friction.static"});
  return max_memory_gb;
}

MaterialParams read_material(const Input& in, const std::string& name, const std::string& path) {
  const YAML::Node mats = in.cfg["materials"];
  YAML::Node m;
  if (mats[name]) m.reset(mats[name]);
  if (!m.IsDefined() || m.IsNull()) {
    if (name != "default") {
      std::string list = "default";
      for (auto it = mats.begin(); it != mats.end(); ++it) list += ", " + it->first.as<std::string>();
      in.ctx.fail(path, in.in_node(path), "unknown material '" + name + "'; defined: " + list);
    }
    // The implicit default material: every key at its schema default.
    m.reset(schema::resolve(YAML::Node(YAML::NodeType::Map), material_schema(), in.ctx, "materials.default"));
  }
  MaterialParams mp;
  material_section().read(mp, m);
  // A constraint reading the material's keys gets them from `m` (defaults filled); one with a
  // section of its own is on for this material when that section is in the input.
  const YAML::Node given = in.in["materials"] ? in.in["materials"][name] : YAML::Node();
  for (const auto& e : material_constraints().entries()) {
    if (e.params.empty()) continue;
    if (on_for_every_material(e))
      mp.constraints[e.name] = read_params(e.params, m);
    else if (given && given.IsMap() && given[e.name])
      mp.constraints[e.name] = read_params(e.params, m[e.name]);
  }
  return mp;
}

}  // namespace ccfr::io::scene
