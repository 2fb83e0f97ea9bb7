#pragma once
#include <string>
#include <vector>

#include "memory.hpp"

namespace ccfr::io::scene {
/// Element counts the generator of `shape` will make, from its keys (0 for a mesh: unknown until read).
Counts predict_counts(const YAML::Node& shape, ObjectKind kind);
/// The shape types made by a generator (the schema's other variant is `mesh`).
std::vector<std::string> generator_types();
}  // namespace ccfr::io::scene
