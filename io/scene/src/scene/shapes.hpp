#pragma once
#include <string>
#include <utility>
#include <vector>

#include "memory.hpp"

namespace ccfr::io::scene {
/// Element counts the generator of `shape` will make, from its keys (0 for a mesh: unknown until read).
Counts predict_counts(const YAML::Node& shape, ObjectKind kind);
/// The variants of the schema's objects[].shape: each generator's keys, then `mesh`'s.
std::vector<std::pair<std::string, schema::NodePtr>> shape_variants();
/// The keys of shape type mesh (mesh_sources.cpp).
schema::NodePtr mesh_schema();
/// The shape types made by a generator (the schema's other variant is `mesh`).
std::vector<std::string> generator_types();
}  // namespace ccfr::io::scene
