#pragma once
#include "ccfr/solvers/kinematics.hpp"
#include "ccfr/solvers/params.hpp"
#include "scene/bind.hpp"
#include "schema.hpp"

namespace ccfr::io {
/// The scene file schema (see docs/config.md).
const schema::NodePtr& scene_schema();
/// The schema of one entry of `materials`.
const schema::NodePtr& material_schema();
/// Parses YAML text as scene files are parsed (scene_loader.cpp): one document, no control bytes,
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
