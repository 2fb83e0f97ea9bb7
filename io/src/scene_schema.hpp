#pragma once
#include "schema.hpp"

namespace ccfr::io {
/// The scene file schema (see docs/config.md).
const schema::NodePtr& scene_schema();
/// The schema of one entry of `materials`.
const schema::NodePtr& material_schema();
/// Parses YAML text as scene files are parsed (scene_loader.cpp): one document, no control bytes,
/// nesting depth and alias-expanded node count bounded; `what` names the file kind in messages.
YAML::Node parse_bounded_yaml(const std::string& text, const std::string& label, const std::string& what);
}  // namespace ccfr::io
