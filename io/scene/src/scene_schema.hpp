#pragma once
#include "ccfr/io/scene_loader.hpp"
#include "ccfr/solvers/kinematics.hpp"
#include "ccfr/solvers/params.hpp"
#include "scene/bind.hpp"
#include "schema.hpp"

namespace ccfr::io {

// Bounds on physical magnitudes: a value beyond them is a typo (1e300 for 1e3), not a scene. They
// are far beyond any scene ccfr is meant for and leave products such as velocity x time finite.
inline constexpr double kMaxLength = 1e4;    ///< m: coordinates, sizes, lengths, translations
inline constexpr double kMaxSpeed = 1e4;     ///< m/s: velocities
inline constexpr double kMaxAngular = 1e4;   ///< rad/s
inline constexpr double kMaxAccel = 1e4;     ///< m/s²: gravity
inline constexpr double kMaxTime = 1e9;      ///< s: motion start/end
inline constexpr double kMaxScale = 1e4;     ///< uniform scale
inline constexpr double kMaxAngleDeg = 1e6;  ///< degrees
inline constexpr double kMaxDensity = 1e6;   ///< kg/m³ (and the per-area, per-length, per-particle variants)
inline constexpr double kMaxFps = 1e6;
/// Frames per second below this (a frame longer than 1000 s) is a typo: Δt would overflow positions.
inline constexpr double kMinFps = 1e-3;
/// The smallest uniform scale: below it a metre-sized mesh has faces of zero area in double.
inline constexpr double kMinScale = 1e-6;
/// Counts of work (substeps, sweeps, a registered solver's passes): bounded so that every product
/// of them stays in int and a run ends in finite time; time.iterations so that 4 x it stays within
/// time.max_iterations' bound.
inline constexpr long long kMaxCount = 10000;
inline constexpr long long kMaxIterations = 1024;
inline constexpr long long kMaxOuterIterations = 4096;  ///< time.max_iterations, time.max_subdivision
/// Repulsion stiffness k (its compliance is 1/k): both ends kept where 1/k and k Δt² stay finite.
inline constexpr double kMinStiffness = 1e-6, kMaxStiffness = 1e12;
/// Friction coefficients: a Coulomb coefficient of 100 already sticks every contact.
inline constexpr double kMaxFriction = 100;

/// A vec3 the user must give (vec3 without a default is optional: `rotate_axis` and the like).
schema::NodePtr required_vec3(std::string doc, schema::Range r);

/// The scene file schema (see docs/config.md).
const schema::NodePtr& scene_schema();
/// The schema of one entry of `materials`.
const schema::NodePtr& material_schema();
/// Parses YAML text as scene files are parsed (scene/yaml_text.cpp): one document, no control bytes,
/// nesting depth and alias-expanded node count bounded; `what` names the file kind in messages.
YAML::Node parse_bounded_yaml(const std::string& text, const std::string& label, const std::string& what);

// The choice tables of the keys read into enums and flags (the schema lists their strings).
const scene::ChoiceTable<TimeParams::Continuation>& continuation_choices();  ///< time.continuation
const scene::ChoiceTable<ViolationPolicy>& violation_choices();              ///< contact.on_violation
const scene::ChoiceTable<AuditMode>& audit_choices();                        ///< debug.audit
const scene::ChoiceTable<bool>& strand_layout_choices();  ///< objects[].shape.layout of strands: row?

// The schema sections read into parameter structs (scene_schema.cpp declares each key once).
const scene::Section<TimeParams>& time_section();            ///< time
const scene::Section<ContactParams>& contact_section();      ///< contact (without the solvers' own sections)
const scene::Section<DetectionParams>& collision_section();  ///< collision (without the broad phases' own)
const scene::Section<DebugParams>& debug_section();          ///< debug
const scene::Section<OutputParams>& output_section();        ///< output (formats: read_output)
const scene::Section<MaterialParams>& material_section();    ///< one entry of materials
const scene::Section<Motion>& motion_section();              ///< objects[].motion, objects[].pins[].motion
}  // namespace ccfr::io
