// The scene file schema: the single source of truth for keys, types, defaults and ranges.
// docs/config.md is generated from it (`ccfr schema`), and a test checks that they agree.
#include "scene_schema.hpp"

#include "scene/shapes.hpp"

#include <functional>

#include "ccfr/collision/broad_phase.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/io/formats.hpp"
#include "ccfr/solvers/contact_solver.hpp"
#include "ccfr/solvers/material_constraint.hpp"
#include "ccfr/solvers/params.hpp"

namespace ccfr::io {

using namespace schema;

namespace {

NodePtr required_choice(std::function<std::vector<std::string>()> choices, std::string doc) {
  auto n = choice("", std::move(choices), std::move(doc));
  n->default_yaml.reset();
  n->required = true;
  return n;
}

}  // namespace

NodePtr required_vec3(std::string doc, Range r) {
  auto n = vec3(std::nullopt, std::move(doc), r);
  n->optional_absent = false;
  n->required = true;
  return n;
}

// The choice tables: the one mapping between the schema's choice strings and the C++ values.
const scene::ChoiceTable<TimeParams::Continuation>& continuation_choices() {
  static const scene::ChoiceTable<TimeParams::Continuation> t{
      {{"full", TimeParams::Continuation::full}, {"held_back", TimeParams::Continuation::held_back}}};
  return t;
}

const scene::ChoiceTable<ViolationPolicy>& violation_choices() {
  static const scene::ChoiceTable<ViolationPolicy> t{
      {{"auto", ViolationPolicy::automatic}, {"error", ViolationPolicy::error}, {"warn", ViolationPolicy::warn}}};
  return t;
}

const scene::ChoiceTable<AuditMode>& audit_choices() {
  static const scene::ChoiceTable<AuditMode> t{
      {{"off", AuditMode::off}, {"every_frame", AuditMode::every_frame}, {"every_substep", AuditMode::every_substep}}};
  return t;
}

const scene::ChoiceTable<bool>& strand_layout_choices() {
  static const scene::ChoiceTable<bool> t{{{"grid", false}, {"row", true}}};
  return t;
}

// The sections read into parameter structs: key, type, default (the struct's) and reader, once.
const scene::Section<TimeParams>& time_section() {
  using S = TimeParams;
  const Range count{1, static_cast<double>(kMaxCount), false, false};
  static const scene::Section<S> s =
      scene::Section<S>()
          .field("fps", &S::fps, "frames per second", Range{kMinFps, kMaxFps, false, false})
          .field("frames", &S::frames, "frames to simulate", Range::up_to(static_cast<double>(kMaxFrames)))
          .field("substeps", &S::substeps, "substeps per frame", count)
          .field("iterations", &S::iterations,
                 "nominal outer iterations per substep, each with collision detection: a substep ends after "
                 "the first one in which no vertex was held back by the step bound r (fewer may run; stats.csv "
                 "outer_iterations counts them), and goes on past it while one is, or while a solver that "
                 "guarantees separation left a pair inside its offset (time.max_iterations)",
                 Range{1, static_cast<double>(kMaxIterations), false, false})
          .field("max_iterations", &S::max_iterations,
                 "outer iterations continue past `iterations` while a vertex has not reached its intended "
                 "advance (held back by the step bound r) or, under a solver that guarantees separation, a pair "
                 "is inside its offset, up to this many (at least `iterations`); 0 means 4 x iterations",
                 Range{0, static_cast<double>(kMaxOuterIterations), false, false})
          .field("xpbd_sweeps", &S::xpbd_sweeps, "material constraint sweeps per outer iteration", count)
          .field("gravity", &S::gravity, "gravity (m/s²)", Range::within(kMaxAccel))
          .field("damping", &S::damping, "fraction of velocity removed per second", Range{0, 1e3, false, false})
          .field("advance_tolerance", &S::advance_tolerance,
                 "outer iterations stop when no vertex is held back by the step bound by more than tol · r (a "
                 "vertex may thus arrive up to tol · r short per substep; one whose step grows by less than "
                 "that per substep stays at r per substep, a speed limit of r per substep, so keep it far "
                 "below a dt² / r for the accelerations a that matter)",
                 Range::unit())
          .field("advance_shortfall", &S::advance_shortfall,
                 "outer iterations also stop when the step bound cut at most this fraction of the pass's total "
                 "intended advance (summed over movable vertices), even if a few vertices are held back: they "
                 "keep their step of r (counted in clamped_vertices). 0 iterates while any vertex is held "
                 "back",
                 Range::unit())
          .choice("continuation", &S::continuation, continuation_choices(),
                  "what the outer iterations after a substep's first one solve: full, the whole scene again (the "
                  "paper); held_back, only the vertices the step bound held back in the pass before (and those "
                  "around pairs its recount found closer than their offset), every other vertex fixed where it "
                  "stands for that pass, so detection skips pairs of two fixed vertices. Scenes with rigid bodies "
                  "always run full passes")
          .field("max_subdivision", &S::max_subdivision,
                 "most pieces a substep is split into automatically when scripted vertices move more than r or "
                 "the free-flight advance exceeds (max_iterations - 1) r; beyond it a scripted step is an "
                 "error and a dynamic one a warning naming the object",
                 Range{1, static_cast<double>(kMaxOuterIterations), false, false});
  return s;
}

const scene::Section<ContactParams>& contact_section() {
  using S = ContactParams;
  static const scene::Section<S> s =
      scene::Section<S>()
          .name("solver", &S::solver, registered_contact_solvers,
                "contact solver: one of the registered methods (table of contact solvers below)")
          .field("radius", &S::radius, "r: search radius and per-iteration step bound (m)",
                 Range::positive_up_to(kMaxLength))
          .field("offset", &S::offset, "ξ: minimum separation between primitives (m)", Range::up_to(kMaxLength))
          .field("repulsion_range", &S::repulsion_range, "δ: repulsion acts while the gap beyond ξ is below δ (m)",
                 Range::up_to(kMaxLength))
          .field("stiffness", &S::stiffness, "k: repulsion stiffness; XPBD compliance 1/k",
                 Range{kMinStiffness, kMaxStiffness, false, false})
          .field("visibility_width", &S::visibility_width,
                 "δ_v: occlusion smoothstep width of the visibility weights (m); 0 means δ", Range::up_to(kMaxLength))
          .map("friction", "friction on active contacts (Macklin et al. 2014)",
               scene::Section<S>()
                   .field("static", &S::friction_static, "static coefficient μ_s", Range::up_to(kMaxFriction))
                   .field("kinetic", &S::friction_kinetic, "kinetic coefficient μ_k", Range::up_to(kMaxFriction)))
          .field("epsilon", &S::epsilon,
                 "ε: retraction of a projected point toward its anchor, relative to ξ (the region-projection "
                 "solvers use ε ξ; 1e-4 gives 1e-6 m at ξ = 0.01 as in the paper, and stays below the "
                 "per-vertex share of a gap at small ξ)",
                 Range{0, 0.1, false, false})
          .field("analytic_obstacles", &S::analytic_obstacles,
                 "obstacles with an analytic shape (sphere, plane, box, cylinder) also collide "
                 "through their exact SDF")
          .field("momentum", &S::momentum,
                 "contact carries momentum between its two sides: pairs that the candidate positions bring "
                 "closer than their offset are closed by an inelastic contact constraint weighted by both sides' "
                 "inverse masses, and each pair's plane is split between its sides by the motion that leaves "
                 "(the dividing plane moves with the pair), so a body pushes what it hits instead of stopping "
                 "at a fixed plane (docs/feasibility.md, \"Momentum through contact\"); false (default): the "
                 "paper's response (repulsion within δ only) and planes split by mass shares, except in a substep "
                 "whose passes end with pairs closer than their offset, which is solved again with this response "
                 "(stats.csv `substeps_redone`). Under the region-projection solvers, the last outer iteration of a "
                 "substep takes the rest of any step longer than r instead of cutting it (docs/feasibility.md, "
                 "\"The last pass takes the rest of a step\"); two unpinned "
                 "rigid bodies push each other where their candidates overlap and repel each other as one pair "
                 "within δ, their plane split by the motion that leaves (\"Momentum between rigid bodies\"). "
                 "With it, a cloth or strand with static pins is held by its tethers (contact.tethers)")
          .field("free_islands", &S::free_islands,
                 "free islands keep their momentum (default true; region-projection solvers, in scenes "
                 "where no obstacle collides through its distance function, contact.analytic_obstacles): bodies "
                 "(tet solids, cloths, "
                 "shells) close to one another with nothing "
                 "pinned or scripted among them are carried together by their common translation before each "
                 "pass, a grain whose sweep along its step meets nothing is carried that step, and pieces (bodies, "
                 "rigid ones too, single strands, single grains) that touch only one "
                 "another (or nothing) get back the linear momentum the projection took and the angular momentum "
                 "they had at the substep's start, as one shift and one turn of them all, made only where it "
                 "keeps them more than ξ + δ from everything else, and their pairs split each gap by the motion "
                 "that leaves, so that pieces flying together within reach keep their gaps (docs/feasibility.md, "
                 "\"A free island keeps its momentum\"); false: the paper's projection alone, which takes the momentum "
                 "of what it holds and keeps a grain to r a pass "
                 "(two soft solids meeting in free space stop), and XPBD's loss of a free body's spin. "
                 "contact.momentum's exact momenta between free bodies rely on it")
          .field("tethers", &S::tethers,
                 "with contact.momentum: every cloth and strand with static pins (not scripted ones) gets "
                 "long-range attachments (Kim et al. 2012): each movable vertex is kept within (1 + "
                 "tether_slack) L of its nearest pinned vertices, L their rest distance: straight on a flat sheet "
                 "that is its convex hull (the 4 nearest pins of each group), along the rest edges otherwise (a "
                 "strand's arc length; on a curved or cut sheet a path up to about 1.4 times the geodesic, a "
                 "looser bound). Enforced after each material sweep (the contact's later steps may carry a vertex "
                 "a few percent past it within a substep); the momentum response pushes a vertex at most to its "
                 "tether and gives the rest of the overlap to the other side, so a heavy body is caught by the "
                 "cloth's pins instead of stretching it (docs/feasibility.md, \"Tethers\"); false: the cloth's "
                 "tension acts only through its material sweeps")
          .field("tether_slack", &S::tether_slack,
                 "s: how far a tether may exceed its rest distance L, relative (0.02: 2 %): on a flat sheet the "
                 "stretch a pinned cloth may take as a whole under contact.momentum",
                 Range{0, 1, false, false})
          .field("sliding", &S::sliding,
                 "each pair's separating plane may turn toward the pair's closest-point direction at the "
                 "candidate positions, where the turned plane still keeps the pair's current positions at least "
                 "its offset apart and cuts the candidates less, so that a body or a cloth slides over a "
                 "tessellated surface instead of being lifted or held back at its vertices (docs/feasibility.md, "
                 "\"Sliding planes\"); false: the paper's closest-point planes only (region-projection solvers)")
          .field("adaptive_reach", &S::adaptive_reach,
                 "f > 0: each outer iteration gives each vertex its own reach ρ = min(r, max(f r, δ) + 2 ‖s‖), "
                 "s its intended step (the material solve's result against the pass's start); r where the "
                 "pass before held it back or left pairs inside their offsets, and for a rigid body's vertex; "
                 "its known step for a fixed or scripted one. Detection pairs primitives within ρ_A + ρ_B + ξ "
                 "instead of 2r + ξ and the step bound keeps each vertex within its ρ, so slow vertices in a "
                 "dense pile test far fewer pairs (docs/feasibility.md, \"Adaptive reach\"); 0 (default): the "
                 "paper's uniform r. Region-projection solvers (ccfr, exact_projection, successive_projection); "
                 "not with collision.reuse_skin",
                 Range{0, 1, false, false})
          .choice("on_violation", &S::on_violation, violation_choices(),
                  "a substep that ends with pairs closer than their offset (or a deformed rigid body): "
                  "`error` stops the run before the frame is written (non-zero exit), `warn` logs at error "
                  "level and goes on, `auto` is error for the solvers that guarantee separation (ccfr, "
                  "exact_projection) and warn for the baselines");
  return s;
}

const scene::Section<DetectionParams>& collision_section() {
  using S = DetectionParams;
  static const scene::Section<S> s =
      scene::Section<S>()
          .name("broad_phase", &S::broad_phase, broad_phase_names, "broad phase")
          .field("reuse_skin", &S::reuse_skin,
                 "skin s of the sub-pair list kept between detection passes, in units of r: a pass that runs the "
                 "broad phase lists every sub-pair within 2r + ξ + s r, and later passes evaluate only those while "
                 "the motion since cannot have brought another into range: every vertex within s r / 2 of its "
                 "listed position shifted by one common translation, and within max(s r, g - 2r - ξ) against "
                 "obstacles at rest g away (same contacts, same order; docs/feasibility.md); 0 runs the broad "
                 "phase in every pass",
                 Range{0, 100, false, false});
  return s;
}

const scene::Section<DebugParams>& debug_section() {
  using S = DebugParams;
  static const scene::Section<S> s =
      scene::Section<S>()
          .choice("audit", &S::audit, audit_choices(),
                  "exact penetration audit during the run; fills the `penetrations` column of stats.csv")
          .field("audit_tolerance", &S::audit_tolerance, "the audit flags pairs closer than (1 - tol) ξ",
                 Range{0, 1, false, true});
  return s;
}

const scene::Section<OutputParams>& output_section() {
  using S = OutputParams;
  static const scene::Section<S> s =
      scene::Section<S>()
          .field("frames", &S::frames, "write frames (in every format of `formats`)")
          .field("every", &S::every, "write every k-th frame (frame 0 always)",
                 Range{1, static_cast<double>(kMaxFrames), false, false})
          .field("checkpoint_every", &S::checkpoint_every,
                 "write a checkpoint every k-th frame, and when the run is "
                 "interrupted (0: never); `ccfr run --resume DIR` continues from it",
                 Range::up_to(static_cast<double>(kMaxFrames)))
          // interop (docs/interop.md): formats besides the OBJ frames; read by read_output (an empty
          // list is refused there, with the key's line)
          .other("formats", list("formats of the frames; absent: [obj]; each one of the registered frame "
                                 "writers (table of output formats below)",
                                 choice("obj", frame_writer_names, "an output format")));
  return s;
}

const scene::Section<MaterialParams>& material_section() {
  using S = MaterialParams;
  // The material constraints' keys (stretch_compliance, ...) join these in material_fields().
  static const scene::Section<S> s =
      scene::Section<S>()
          .field("density", &S::density,
                 "kg/m² for cloth and shells, kg/m for strands, kg/m³ for solids and rigids, kg per particle",
                 Range::positive_up_to(kMaxDensity))
          .field("friction", &S::friction, "friction coefficient of this material; < 0 uses contact.friction",
                 Range::within(kMaxFriction));
  return s;
}

const scene::Section<Motion>& motion_section() {
  using S = Motion;
  static const scene::Section<S> s =
      scene::Section<S>()
          .field("velocity", &S::velocity, "translation velocity (m/s)", Range::within(kMaxSpeed))
          .field("axis", &S::axis, "rotation axis (world frame, normalised)", Range::within(kMaxLength))
          .field("center", &S::center, "a point on the rotation axis at rest (world frame)", Range::within(kMaxLength))
          .field("angular_velocity", &S::angular_velocity, "rotation rate about `axis` (rad/s, right-handed)",
                 Range::within(kMaxAngular))
          .field("start", &S::start, "time (s) the motion starts", Range::up_to(kMaxTime))
          .field_default("end", &S::end, 1e9, "time (s) the motion stops and holds", Range::up_to(kMaxTime));
  return s;
}

namespace {

NodePtr motion_schema(std::string doc) { return optional_map(std::move(doc), motion_section().fields()); }

NodePtr shape_schema() {
  // The variants are declared with their readers (scene/shapes.cpp, scene/mesh_sources.cpp).
  return variant("the object's geometry: a generator or a mesh file", "type", scene::shape_variants());
}

/// A registered parameter as a schema node: type, default, range and doc come from the registry.
NodePtr param_node(const ParamSpec& spec) {
  const Range r{spec.min, spec.max, spec.min_open, spec.max_open};
  switch (spec.type) {
    case ParamType::boolean:
      return boolean(std::get<bool>(spec.default_value), spec.doc);
    case ParamType::integer: {
      // A registered count (passes, sweeps) is bounded like the time section's counts.
      Range c = r;
      if (c.hi > static_cast<double>(kMaxCount) && std::get<long long>(spec.default_value) <= kMaxCount) {
        c.hi = static_cast<double>(kMaxCount);
        c.hi_open = false;
      }
      return integer(std::get<long long>(spec.default_value), spec.doc, c);
    }
    case ParamType::number:
      return number(std::get<double>(spec.default_value), spec.doc, r);
    case ParamType::choice: {
      auto choices = spec.choices;
      return choice(
          std::get<std::string>(spec.default_value), [choices] { return choices; }, spec.doc);
    }
  }
  return nullptr;
}

/// One map per registered component that has parameters of its own, keyed by its name: the
/// section `<selector's parent>.<name>.*`, valid only while `selector` names that component.
/// `when` says when the section applies, e.g. "only with `contact.solver: ccfr`".
template <class R, class When>
void add_component_sections(std::vector<Field>& fields, const R& registry, When when) {
  for (const auto& e : registry.entries()) {
    if (e.params.empty() || !e.params.front().material_key.empty()) continue;
    for (const auto& f : fields)
      if (f.key == e.name)
        throw Error(registry.kind() + " '" + e.name + "': its name is already a key of the section its parameters " +
                    "would go in; register it under another name");
    std::vector<Field> keys;
    for (const auto& spec : e.params) keys.push_back({spec.key, param_node(spec)});
    fields.push_back(
        {e.name, map("parameters of " + registry.kind() + " `" + e.name + "` (" + e.description + "); " + when(e.name),
                     std::move(keys))});
  }
}

std::function<std::string(const std::string&)> only_with(const std::string& selector) {
  return [selector](const std::string& name) { return "only with `" + selector + ": " + name + "`"; };
}

std::vector<Field> contact_fields() {
  std::vector<Field> f = contact_section().fields();
  add_component_sections(f, contact_solvers(), only_with("contact.solver"));
  return f;
}

std::vector<Field> output_fields() {
  std::vector<Field> f = output_section().fields();
  add_component_sections(f, frame_writers(),
                         [](const std::string& name) { return "only while `output.formats` lists `" + name + "`"; });
  return f;
}

std::vector<Field> material_fields() {
  std::vector<Field> f = material_section().fields();
  // The keys the material constraints read, after density (material_keys(): each key once).
  std::vector<Field> keys;
  for (const ParamSpec& spec : material_keys()) {
    for (const auto& field : f)
      if (field.key == spec.key)
        throw Error("material constraint parameter '" + spec.key +
                    "': a material already has this key; read it under another name");
    keys.push_back({spec.key, param_node(spec)});
  }
  f.insert(f.begin() + 1, keys.begin(), keys.end());
  add_component_sections(f, material_constraints(), [](const std::string&) {
    return std::string("setting the section switches the constraint on for the objects of this material");
  });
  return f;
}

std::vector<Field> collision_fields() {
  std::vector<Field> f = collision_section().fields();
  add_component_sections(f, broad_phases(), only_with("collision.broad_phase"));
  return f;
}

NodePtr build_scene_schema() {
  auto material = map("a material", material_fields());
  auto pin = map(
      "a group of pinned vertices, optionally moved by a script",
      {
          {"indices", index_list("vertex indices local to the object")},
          {"box_min", vec3(std::nullopt, "pin every vertex inside [box_min, box_max] (world frame, after transform)",
                           Range::within(kMaxLength))},
          {"box_max", vec3(std::nullopt, "upper corner of the selection box", Range::within(kMaxLength))},
          {"motion", motion_schema("scripted motion of the pinned vertices (kinematic handle)")},
      });
  auto object = map(
      "one object of the scene",
      {
          {"name", string(std::nullopt, "unique object name (written as `o name` in frames)")},
          {"kind", required_choice(
                       [] {
                         std::vector<std::string> v;
                         for (auto n : object_kind_names()) v.emplace_back(n);
                         return v;
                       },
                       "what the object is: constraints, collision primitives and output")},
          {"material", string(std::string("default"), "name of an entry of `materials`")},
          {"shape", shape_schema()},
          {"transform",
           map("placement of the generated or loaded geometry: scale, rotate, then translate",
               {{"scale", number(1.0, "uniform scale", Range{kMinScale, kMaxScale, false, false})},
                {"rotate_axis", vec3(std::array<double, 3>{0, 1, 0}, "rotation axis", Range::within(kMaxLength))},
                {"rotate_deg", number(0.0, "rotation angle about rotate_axis (degrees)", Range::within(kMaxAngleDeg))},
                {"translate", vec3(std::array<double, 3>{0, 0, 0}, "translation (m)", Range::within(kMaxLength))}})},
          {"velocity",
           vec3(std::array<double, 3>{0, 0, 0}, "initial velocity of every vertex (m/s)", Range::within(kMaxSpeed))},
          {"pins", list("pinned vertex groups", pin)},
          {"motion", motion_schema("obstacles: scripted rigid motion of the whole object")},
          // Obstacle animation (docs/interop.md).
          {"animation",
           optional_map(
               "obstacles: vertex positions from a sequence of OBJ files with the object's vertex count and "
               "order, interpolated linearly per substep (the automatic subdivision keeps each piece's step "
               "below r); the object starts at the first file; `transform` applies to every file",
               {{"path", string(std::nullopt,
                                "printf pattern of the files with one integer, relative to the scene file, "
                                "e.g. meshes/body_%03d.obj")},
                {"first", integer(0, "number of the first file", Range::non_negative())},
                {"count", integer(2, "number of files", Range{2, 100000, false, false})},
                {"fps", number(0.0, "files per second of simulated time; 0 means time.fps", Range::up_to(kMaxFps))}})},
          {"keyframes",
           list("obstacles: keyframed rigid transforms of the placed geometry, slerped and lerped between keys "
                "(held before the first and after the last; the object starts at its pose at time 0)",
                map("one key",
                    {{"time", required_number("time of the key (s)", Range::up_to(kMaxTime))},
                     {"translate", vec3(std::array<double, 3>{0, 0, 0}, "translation (m)", Range::within(kMaxLength))},
                     {"rotate_axis", vec3(std::array<double, 3>{0, 1, 0}, "rotation axis", Range::within(kMaxLength))},
                     {"rotate_deg", number(0.0, "rotation about rotate_axis through `center` (degrees)",
                                           Range::within(kMaxAngleDeg))},
                     {"center", vec3(std::array<double, 3>{0, 0, 0}, "a point on the rotation axis (m)",
                                     Range::within(kMaxLength))}}))},
      });
  return map("a ccfr scene",
             {
                 {"scene", optional_string("scene name (default: the file name without extension)")},
                 {"max_memory",
                  number(0.0,
                         "largest memory (GB) a scene may use: a scene estimated above it is refused while "
                         "loading, naming what each object costs, and a run whose resident memory passes it stops "
                         "after that frame (exit 1, frames whole, a checkpoint to resume from); 0 means the memory the "
                         "machine has available (MemAvailable). Raise it knowingly (`ccfr run --max-memory GB`) when "
                         "the estimate is pessimistic for the scene (docs/performance.md compares it with measured "
                         "peaks)",
                         Range{0, 1e6, false, false})},
                 {"time", map("time stepping", time_section().fields())},
                 {"contact", map("contact handling", contact_fields())},
                 {"collision", map("collision detection", collision_fields())},
                 {"debug", map("diagnostics", debug_section().fields())},
                 {"output", map("what is written", output_fields())},
                 {"materials", dict("named materials; `default` exists unless redefined", material)},
                 {"objects", list("the objects of the scene", object)},
             });
}

}  // namespace

const NodePtr& scene_schema() {
  // Rebuilt when a component was registered since (downstream code may register after a first load).
  static NodePtr s;
  static size_t built_for = 0;
  const size_t n = contact_solvers().entries().size() + broad_phases().entries().size() +
                   frame_writers().entries().size() + material_constraints().entries().size();
  if (!s || n != built_for) s = build_scene_schema(), built_for = n;
  return s;
}

const NodePtr& material_schema() {
  static NodePtr m;
  for (const auto& f : scene_schema()->fields)
    if (f.key == "materials") m = f.node->item;
  return m;
}

}  // namespace ccfr::io
