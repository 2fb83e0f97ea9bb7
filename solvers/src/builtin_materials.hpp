#pragma once
// The built-in material constraints: one file per constraint under solvers/src/materials/, named by
// its key, defining register_material_constraint_<key>(). CMake lists those files into
// builtin_material_constraints.inc, which material_constraints() expands on first use. Their order
// in a sweep is each batch's sweep_rank(), not the order of the files. Private to solvers/.
#include "ccfr/solvers/material_constraint.hpp"

namespace ccfr {
#define CCFR_BUILTIN_MATERIAL_CONSTRAINT(key) \
  void register_material_constraint_##key(MaterialConstraintRegistry& registry);
#include "builtin_material_constraints.inc"
#undef CCFR_BUILTIN_MATERIAL_CONSTRAINT

/// `compliance` of the two bending constraints, both read from the material's `bend_compliance`.
inline ParamSpec bend_compliance_param() {
  return ParamSpec::number("compliance", 0.1, "XPBD compliance of bending (1/(N m)); cloth, shells and strands", 0.0,
                           kMaxCompliance)
      .from_material("bend_compliance");
}
}  // namespace ccfr
