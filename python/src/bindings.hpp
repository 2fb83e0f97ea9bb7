#pragma once
// What every binding file of ccfr._core includes (the pybind11 headers, so that each one converts
// the same C++ types alike) and the define_* functions that module.cpp calls in order.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>

namespace ccfr::python {

namespace py = pybind11;
namespace fs = std::filesystem;

// A type that one file binds or throws and another takes or catches (PyScene, PySimulation,
// MissingFile, ...) is declared in a bind_*.hpp in this namespace, never in an anonymous one:
// pybind11 and `catch` match types by identity across the files.

/// ccfr.Error and its subclasses, and the translation of the C++ exceptions into them.
void define_errors(py::module_& m);
/// set_log_level and version.
void define_library(py::module_& m);
/// ccfr.Scene and its loaders load_scene, load_scene_text and _load_scene_arrays.
void define_scene(py::module_& m);
/// ccfr.Simulation.
void define_simulation(py::module_& m);
/// ccfr.Run (run directories).
void define_run(py::module_& m);
/// ccfr.FrameAudit, ccfr.AuditResult and audit.
void define_audit(py::module_& m);
/// ccfr.Projection, projector_names and project.
void define_projection(py::module_& m);
/// point_edge, point_triangle and edge_edge.
void define_closest_points(py::module_& m);

}  // namespace ccfr::python
