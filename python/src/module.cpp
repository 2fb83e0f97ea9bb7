// The Python module `ccfr._core` (pybind11): scenes, stepping, run directories, the audit, the
// projectors and the closest-point kernels. python/ccfr/__init__.py re-exports it; docs/python.md.
// Each define_* of bindings.hpp adds one class or concern; the order is the module's attribute order.
#include "bindings.hpp"

PYBIND11_MODULE(_core, m) {
  namespace python = ccfr::python;
  m.doc() = "ccfr: XPBD with Convex Collision-Free Regions (C++ core bindings; import ccfr, not ccfr._core)";
  // Each docstring starts with a text signature "name(...)\n--\n\n", which CPython turns into
  // __text_signature__ so that inspect.signature reads the parameters (pybind11's own would not).
  pybind11::options options;
  options.disable_function_signatures();

  python::define_errors(m);
  python::define_library(m);
  python::define_scene(m);
  python::define_simulation(m);
  python::define_run(m);
  python::define_audit(m);
  python::define_projection(m);
  python::define_closest_points(m);
}
