// ccfr.Error and its subclasses (created at import) and the translator that raises them for the
// C++ exceptions, with the C++ error's fields as attributes.
#include "bind_errors.hpp"

#include <cerrno>
#include <exception>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "ccfr/core/error.hpp"

namespace ccfr::python {

namespace {

// Exception classes created at import (ccfr.Error and its subclasses); see translate() below.
PyObject* g_error = nullptr;
PyObject* g_config_error = nullptr;
PyObject* g_numerical_error = nullptr;
PyObject* g_guarantee_error = nullptr;
PyObject* g_missing_file = nullptr;  // ccfr.MissingFileError: ccfr.Error and FileNotFoundError
PyObject* g_missing_mesh = nullptr;  // ccfr.MissingMeshError: ccfr.ConfigError and MissingFileError

// Raises `cls(message)` with the C++ error's fields as attributes.
void raise_with(PyObject* cls, const std::string& message,
                const std::vector<std::pair<const char*, py::object>>& attrs) {
  py::object inst = py::reinterpret_borrow<py::object>(cls)(message);
  for (const auto& [k, v] : attrs) inst.attr(k) = v;
  PyErr_SetObject(cls, inst.ptr());
}

// Creates the exception classes above (once, at import).
void create_exception_classes() {
  // Exceptions: ccfr.Error (a RuntimeError) and its subclasses carrying the C++ fields.
  g_error = PyErr_NewExceptionWithDoc("ccfr.Error", "A ccfr error that is the user's to fix; str() is the message.",
                                      PyExc_RuntimeError, nullptr);
  g_config_error = PyErr_NewExceptionWithDoc(
      "ccfr.ConfigError", "A configuration error: attributes file, key_path, line (0 when unknown) and detail.",
      g_error, nullptr);
  g_numerical_error = PyErr_NewExceptionWithDoc(
      "ccfr.NumericalError", "A non-finite position: attributes frame, vertex and stage.", g_error, nullptr);
  g_guarantee_error = PyErr_NewExceptionWithDoc(
      "ccfr.GuaranteeError", "The run cannot keep its separation promise: attribute frame.", g_error, nullptr);
  // Missing files are FileNotFoundError too (errno, filename), while str() stays ccfr's message.
  {
    py::tuple bases = py::make_tuple(py::handle(g_error), py::handle(PyExc_FileNotFoundError));
    g_missing_file = PyErr_NewExceptionWithDoc(
        "ccfr.MissingFileError",
        "A scene file or run directory that does not exist: a ccfr.Error and a FileNotFoundError (errno ENOENT, "
        "filename the path).",
        bases.ptr(), nullptr);
    py::cpp_function message([](const py::object& self) { return py::str(py::tuple(self.attr("args"))[0]); },
                             py::name("__str__"), py::doc("The ccfr message (what `ccfr run` prints)."));
    py::handle(g_missing_file).attr("__str__") = py::reinterpret_steal<py::object>(PyInstanceMethod_New(message.ptr()));
    py::tuple mesh_bases = py::make_tuple(py::handle(g_config_error), py::handle(g_missing_file));
    g_missing_mesh = PyErr_NewExceptionWithDoc(
        "ccfr.MissingMeshError",
        "A mesh file named by a scene that does not exist: a ccfr.ConfigError (file, key_path, line, detail) and a "
        "ccfr.MissingFileError (filename the mesh path).",
        mesh_bases.ptr(), nullptr);
  }
}

// Raises the Python exception of the ccfr::Error that `p` holds (the most derived class first);
// other exceptions are left to pybind11's own translators.
void translate(std::exception_ptr p) {
  try {
    if (p) std::rethrow_exception(p);
  } catch (const MissingMesh& e) {
    raise_with(g_missing_mesh, e.what(),
               {{"file", py::str(e.file())},
                {"key_path", py::str(e.key_path())},
                {"line", py::int_(e.line())},
                {"detail", py::str(e.detail())},
                {"errno", py::int_(ENOENT)},
                {"filename", py::str(e.path.string())}});
  } catch (const MissingFile& e) {
    raise_with(g_missing_file, e.what(), {{"errno", py::int_(ENOENT)}, {"filename", py::str(e.path.string())}});
  } catch (const ConfigError& e) {
    raise_with(g_config_error, e.what(),
               {{"file", py::str(e.file())},
                {"key_path", py::str(e.key_path())},
                {"line", py::int_(e.line())},
                {"detail", py::str(e.detail())}});
  } catch (const NumericalError& e) {
    raise_with(g_numerical_error, e.what(),
               {{"frame", py::int_(e.frame())}, {"vertex", py::int_(e.vertex())}, {"stage", py::str(e.stage())}});
  } catch (const GuaranteeError& e) {
    raise_with(g_guarantee_error, e.what(), {{"frame", py::int_(e.frame())}});
  } catch (const Error& e) {
    raise_with(g_error, e.what(), {});
  }
}

}  // namespace

void define_errors(py::module_& m) {
  create_exception_classes();
  m.add_object("MissingFileError", py::handle(g_missing_file));
  m.add_object("MissingMeshError", py::handle(g_missing_mesh));
  m.add_object("Error", py::handle(g_error));
  m.add_object("ConfigError", py::handle(g_config_error));
  m.add_object("NumericalError", py::handle(g_numerical_error));
  m.add_object("GuaranteeError", py::handle(g_guarantee_error));
  py::register_exception_translator(translate);
}

}  // namespace ccfr::python
