#pragma once
#include "schema.hpp"

namespace ccfr::io {
/// The scene file schema (see docs/config.md).
const schema::NodePtr& scene_schema();
/// The schema of one entry of `materials`.
const schema::NodePtr& material_schema();
}  // namespace ccfr::io
