// The Python module `ccfr._core` (pybind11): scenes, stepping, run directories, the audit, the
// projectors and the closest-point kernels. python/ccfr/__init__.py re-exports it; docs/python.md.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cerrno>
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "ccfr/core/bounds.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/feasibility/projector.hpp"
#include "ccfr/geometry/distance.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/output.hpp"
#include "ccfr/io/run_audit.hpp"
#include "ccfr/io/run_recorder.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "ccfr/solvers/simulation.hpp"

namespace py = pybind11;
namespace fs = std::filesystem;

namespace ccfr::python {

namespace {

// Exception classes created at import (ccfr.Error and its subclasses); see the translator below.
PyObject* g_error = nullptr;
PyObject* g_config_error = nullptr;
PyObject* g_numerical_error = nullptr;
PyObject* g_guarantee_error = nullptr;
PyObject* g_missing_file = nullptr;  // ccfr.MissingFileError: ccfr.Error and FileNotFoundError
PyObject* g_missing_mesh = nullptr;  // ccfr.MissingMeshError: ccfr.ConfigError and MissingFileError

/// A scene file or run directory that does not exist (raised as ccfr.MissingFileError).
struct MissingFile : Error {
  MissingFile(const std::string& message, fs::path p) : Error(message), path(std::move(p)) {}
  fs::path path;
};

/// A mesh file named by a scene that does not exist (ccfr.MissingMeshError, a ConfigError too).
struct MissingMesh : ConfigError {
  MissingMesh(const ConfigError& e, fs::path p)
      : ConfigError(e.file(), e.key_path(), e.line(), e.detail()), path(std::move(p)) {}
  fs::path path;
};

// Raises `cls(message)` with the C++ error's fields as attributes.
void raise_with(PyObject* cls, const std::string& message,
                const std::vector<std::pair<const char*, py::object>>& attrs) {
  py::object inst = py::reinterpret_borrow<py::object>(cls)(message);
  for (const auto& [k, v] : attrs) inst.attr(k) = v;
  PyErr_SetObject(cls, inst.ptr());
}

/// A loaded scene and how to load it again with more overrides (Simulation(solver=...) goes
/// through the loader exactly like `ccfr run --solver`).
struct PyScene {
  io::LoadedScene loaded;
  std::vector<std::string> overrides;
  std::function<io::LoadedScene(const std::vector<std::string>&)> load;
};

/// "key.path=value" overrides from a dict (values written as JSON, which YAML reads) or a list.
/// NumPy scalars and arrays (anything with tolist()) are written as the Python values they hold.
/// A non-empty dict value is merged key by key, as `--set` does with key paths: {"time":
/// {"frames": 3}} is time.frames=3 and leaves the other keys of `time` as they were.
std::vector<std::string> to_overrides(const py::object& o) {
  std::vector<std::string> out;
  if (o.is_none()) return out;
  if (py::isinstance<py::dict>(o)) {
    const auto flat = py::dict();
    std::function<void(const std::string&, const py::dict&)> flatten = [&](const std::string& prefix,
                                                                           const py::dict& d) {
      for (auto item : d) {
        const std::string key = prefix + std::string(py::str(item.first));
        if (py::isinstance<py::dict>(item.second) && py::len(item.second) > 0)
          flatten(key + ".", py::reinterpret_borrow<py::dict>(item.second));
        else
          flat[py::str(key)] = item.second;
      }
    };
    flatten("", py::reinterpret_borrow<py::dict>(o));
    py::object dumps = py::module_::import("json").attr("dumps");
    py::cpp_function plain([](const py::object& v) -> py::object {
      if (py::hasattr(v, "tolist")) return v.attr("tolist")();
      throw py::type_error("an override value must be a number, string, bool, list or dict, not " +
                           std::string(py::str(py::type::handle_of(v).attr("__name__"))));
    });
    for (auto item : flat) {
      const std::string key = py::str(item.first);
      py::object value = py::reinterpret_borrow<py::object>(item.second);
      const std::string text = py::isinstance<py::str>(value)
                                   ? value.cast<std::string>()
                                   : dumps(value, py::arg("default") = plain).cast<std::string>();
      out.push_back(key + "=" + text);
    }
    return out;
  }
  if (py::isinstance<py::str>(o)) throw py::type_error("overrides must be a dict or a list of strings, not a string");
  for (auto item : o) out.push_back(py::str(item));
  return out;
}

using Loader = std::function<io::LoadedScene(const std::vector<std::string>&)>;

/// Runs `load`, relabelling what the loader blames on `--set` (it serves the command line) as the
/// Python argument that carried it: "overrides (key=value)", or `solver_label` for `solver_item`.
/// A mesh file that does not exist becomes MissingMesh.
io::LoadedScene load_labelled(const Loader& load, const std::vector<std::string>& overrides,
                              const std::string& solver_item = "", const std::string& solver_label = "") {
  auto label = [&](const std::string& item) {
    return !solver_item.empty() && item == solver_item ? solver_label : "overrides (" + item + ")";
  };
  try {
    return load(overrides);
  } catch (const ConfigError& e) {
    for (const auto& item : overrides)
      if (e.file() == "command line (--set " + item + ")") throw ConfigError(label(item), e.key_path(), 0, e.detail());
    // The loader's message for a mesh path it could not find; the file system confirms it.
    const std::string head = "mesh file '", tail = "' does not exist";
    const std::string& d = e.detail();
    if (d.size() > head.size() + tail.size() && d.rfind(head, 0) == 0 && d.ends_with(tail)) {
      const fs::path p = d.substr(head.size(), d.size() - head.size() - tail.size());
      std::error_code ec;
      if (fs::status(p, ec).type() == fs::file_type::not_found) throw MissingMesh(e, p);
    }
    throw;
  } catch (const Error& e) {
    // apply_override's own refusals ("--set 'ITEM': ...") name the item but no key path.
    const std::string what = e.what();
    for (const auto& item : overrides) {
      const std::string prefix = "--set '" + item + "': ";
      if (what.rfind(prefix, 0) == 0) {
        const auto eq = item.find('=');
        throw ConfigError(label(item), item.substr(0, eq), 0, what.substr(prefix.size()));
      }
    }
    throw;
  }
}

std::shared_ptr<PyScene> make_scene(Loader load, std::vector<std::string> overrides) {
  auto s = std::make_shared<PyScene>();
  s->loaded = load_labelled(load, overrides);
  s->overrides = std::move(overrides);
  s->load = std::move(load);
  return s;
}

/// Runs `f`; a ccfr::Error while `path` does not exist becomes MissingFile with the same message.
template <class F>
auto require_existing(const fs::path& path, F&& f) {
  try {
    return f();
  } catch (const ConfigError&) {
    throw;
  } catch (const Error& e) {
    std::error_code ec;
    if (!path.empty() && fs::status(path, ec).type() == fs::file_type::not_found) throw MissingFile(e.what(), path);
    throw;
  }
}

/// One stats.csv row as a dict, key by key from kStatsColumns (in file order): ints for integer
/// columns, floats for the others, None for an unknown value where the table says so.
py::dict frame_stats_dict(const FrameStats& s) {
  py::dict d;
  for (const StatsColumn& c : kStatsColumns) {
    const py::str key(c.name.data(), c.name.size());
    if (c.python == StatsPython::none && c.is_unknown(s))
      d[key] = py::none();
    else
      c.visit(s, [&](auto v) { d[key] = v; });
  }
  return d;
}

using RowArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IndexArray = py::array_t<Index, py::array::c_style | py::array::forcecast>;

/// `h` as a float64 array; real numbers only (forcecast would drop a complex part with a warning,
/// or parse strings): other dtypes are a ValueError naming `what`.
RowArray real_array(const py::handle& h, const char* what) {
  if (py::array raw = py::array::ensure(h);
      raw && raw.size() > 0 && std::string_view("fiub").find(raw.dtype().kind()) == std::string_view::npos)
    throw py::value_error(std::string(what) + " must hold real numbers (got dtype " +
                          std::string(py::str(raw.dtype())) + ")");
  return RowArray::ensure(h);
}

/// An (n, 3) float array as positions; `what` names it in errors.
Positions to_positions(const py::handle& h, const char* what) {
  RowArray a = real_array(h, what);
  if (!a || a.ndim() != 2 || a.shape(1) != 3)
    throw py::value_error(std::string(what) + " must be an (n, 3) array of numbers");
  Positions p(static_cast<size_t>(a.shape(0)));
  auto r = a.unchecked<2>();
  for (py::ssize_t i = 0; i < a.shape(0); ++i) p[i] = Vec3(r(i, 0), r(i, 1), r(i, 2));
  return p;
}

template <int N>
std::vector<Eigen::Matrix<Index, N, 1>> to_rows(const py::handle& h, const char* what) {
  std::vector<Eigen::Matrix<Index, N, 1>> out;
  if (h.is_none()) return out;
  py::array raw = py::array::ensure(h);
  if (!raw) throw py::value_error(std::string(what) + " must be an (n, " + std::to_string(N) + ") integer array");
  if (raw.size() == 0) return out;
  if (raw.dtype().kind() != 'i' && raw.dtype().kind() != 'u')
    throw py::value_error(std::string(what) + " must hold integers (got dtype " + std::string(py::str(raw.dtype())) +
                          ")");
  if (raw.ndim() != 2 || raw.shape(1) != N)
    throw py::value_error(std::string(what) + " must be an (n, " + std::to_string(N) + ") integer array");
  // Read in the array's own signedness: 2**63 as uint64 is not the int64 -2**63.
  const auto copy = [&]<class T>(T) {
    py::array_t<T, py::array::c_style | py::array::forcecast> a(raw);
    auto r = a.template unchecked<2>();
    out.resize(static_cast<size_t>(a.shape(0)));
    for (py::ssize_t i = 0; i < a.shape(0); ++i)
      for (int k = 0; k < N; ++k) {
        const T v = r(i, k);
        // Out-of-range indices are reported by the loader with the object's key path; only values
        // that do not fit an index are refused here.
        if (std::cmp_less(v, std::numeric_limits<Index>::min()) ||
            std::cmp_greater(v, std::numeric_limits<Index>::max()))
          throw py::value_error(std::string(what) + " row " + std::to_string(i) + ": index " + std::to_string(v) +
                                " does not fit 32 bits");
        out[i][k] = static_cast<Index>(v);
      }
  };
  if (raw.dtype().kind() == 'u')
    copy((unsigned long long)0);
  else
    copy((long long)0);
  return out;
}

/// A read-only NumPy view of a position buffer, kept alive by `owner`.
py::array view(const Positions& p, py::handle owner) {
  py::array a(py::dtype::of<double>(), {static_cast<py::ssize_t>(p.size()), py::ssize_t{3}},
              {static_cast<py::ssize_t>(sizeof(Vec3)), static_cast<py::ssize_t>(sizeof(double))},
              p.empty() ? nullptr : p.front().data(), owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}
static_assert(sizeof(Vec3) == 3 * sizeof(double), "Positions must be a packed (n, 3) array for the NumPy views");

/// The simulation with the loaded scene it came from (its resolved configuration goes to run.json).
struct PySimulation {
  std::string resolved_json;
  io::MemoryEstimate memory;  // the estimate the scene was admitted with (run.json `memory`)
  std::unique_ptr<Simulation> sim;
  std::optional<FrameStats> last;
  int threads = 0;
};

/// One row per vertex of the simulation, every value finite: `what` (positions or velocities) as
/// set_positions / set_velocities take it; anything else is a ValueError naming the row.
Positions state_rows(const PySimulation& s, const py::object& h, const char* what) {
  Positions p = to_positions(h, what);
  const size_t n = static_cast<size_t>(s.sim->topology().num_vertices());
  if (p.size() != n)
    throw py::value_error(std::string(what) + ": " + std::to_string(p.size()) + " rows given, the scene has " +
                          std::to_string(n) + " vertices");
  for (size_t i = 0; i < p.size(); ++i)
    if (!p[i].allFinite()) throw py::value_error(std::string(what) + " row " + std::to_string(i) + " is not finite");
  return p;
}

/// `with ccfr.Run(sim, dir) as run:` writes the run directory of `ccfr run` (io::RunRecorder).
struct PyRun {
  py::object sim_owner;  // keeps the simulation alive
  PySimulation* sim = nullptr;
  std::unique_ptr<io::RunRecorder> recorder;
  bool started = false, finished = false;
};

FrameStats step_once(PySimulation& s) {
  FrameStats fs;
  {
    py::gil_scoped_release release;
    fs = s.sim->step_frame();
  }
  s.last = fs;
  return fs;
}

}  // namespace

}  // namespace ccfr::python

using namespace ccfr;
using namespace ccfr::python;

PYBIND11_MODULE(_core, m) {
  m.doc() = "ccfr: XPBD with Convex Collision-Free Regions (C++ core bindings; import ccfr, not ccfr._core)";
  // Each docstring starts with a text signature "name(...)\n--\n\n", which CPython turns into
  // __text_signature__ so that inspect.signature reads the parameters (pybind11's own would not).
  py::options options;
  options.disable_function_signatures();

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
  m.add_object("MissingFileError", py::handle(g_missing_file));
  m.add_object("MissingMeshError", py::handle(g_missing_mesh));
  m.add_object("Error", py::handle(g_error));
  m.add_object("ConfigError", py::handle(g_config_error));
  m.add_object("NumericalError", py::handle(g_numerical_error));
  m.add_object("GuaranteeError", py::handle(g_guarantee_error));
  py::register_exception_translator([](std::exception_ptr p) {
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
  });

  m.def(
      "set_log_level", [](const std::string& level) { init_logging(level); }, py::arg("level"),
      "set_log_level(level)\n--\n\nSets the level of ccfr's log on stderr: trace, debug, info, warn (the default in "
      "Python), error or off.");
  m.def("version", &io::version, "version()\n--\n\nThe library version (the CMake project version).");

  // ---- scenes
  py::class_<PyScene, std::shared_ptr<PyScene>>(m, "Scene",
                                                "A validated scene: objects, state and parameters. Build it with "
                                                "ccfr.load_scene or ccfr.Scene.from_arrays.")
      .def_property_readonly(
          "name", [](const PyScene& s) { return s.loaded.scene.params.scene_name; }, "The scene's `scene` key.")
      .def_property_readonly(
          "num_vertices", [](const PyScene& s) { return s.loaded.scene.topo.num_vertices(); },
          "Vertices of all objects together.")
      .def_property_readonly(
          "source", [](const PyScene& s) { return s.loaded.source.string(); },
          "The scene file ('' when built from text or arrays).")
      .def_property_readonly(
          "overrides", [](const PyScene& s) { return s.overrides; },
          "The overrides applied, as key.path=value strings.")
      .def_property_readonly(
          "config_json", [](const PyScene& s) { return s.loaded.resolved_json; },
          "The configuration with every default filled in, as JSON (what run.json records).")
      .def_property_readonly(
          "objects",
          [](const PyScene& s) {
            py::list out;
            for (const auto& o : s.loaded.scene.topo.objects) {
              py::dict d;
              d["name"] = o.name;
              d["kind"] = std::string(to_string(o.kind));
              d["vertex_begin"] = o.vertex_begin;
              d["vertex_end"] = o.vertex_end;
              out.append(d);
            }
            return out;
          },
          "One dict per object: name, kind and its global vertex range [vertex_begin, vertex_end).")
      .def_property_readonly(
          "positions",
          [](const PyScene& s) { return py::array(view(s.loaded.scene.state.x, py::none())).attr("copy")(); },
          "The initial positions, an (n, 3) copy.")
      .def_property_readonly(
          "faces",
          [](const PyScene& s) {
            const auto& f = s.loaded.scene.topo.faces;
            py::array_t<Index> a({static_cast<py::ssize_t>(f.size()), py::ssize_t{3}});
            auto r = a.mutable_unchecked<2>();
            for (size_t i = 0; i < f.size(); ++i)
              for (int k = 0; k < 3; ++k) r(i, k) = f[i][k];
            return a;
          },
          "Surface triangles with global vertex indices, (#F, 3).")
      .def(
          "with_overrides",
          [](const PyScene& s, const py::object& overrides) {
            std::vector<std::string> o = s.overrides;
            for (auto& x : to_overrides(overrides)) o.push_back(std::move(x));
            return make_scene(s.load, std::move(o));
          },
          py::arg("overrides"),
          "with_overrides(self, /, overrides)\n--\n\nThe same scene loaded again with more overrides (validated like "
          "--set).")
      .def("__repr__", [](const PyScene& s) {
        return "<ccfr.Scene '" + s.loaded.scene.params.scene_name +
               "': " + std::to_string(s.loaded.scene.topo.objects.size()) + " objects, " +
               std::to_string(s.loaded.scene.topo.num_vertices()) + " vertices>";
      });

  m.def(
      "load_scene",
      [](const fs::path& path, const py::object& overrides) {
        auto o = to_overrides(overrides);
        return require_existing(path, [&] {
          return make_scene([path](const std::vector<std::string>& v) { return io::load_scene(path, v); }, o);
        });
      },
      py::arg("path"), py::arg("overrides") = py::none(),
      "load_scene(path, overrides=None)\n--\n\nLoads a YAML scene file. overrides: {\"contact.offset\": 0.02} or "
      "[\"contact.offset=0.02\"], applied "
      "before validation like `ccfr run --set`. Raises ccfr.ConfigError naming file, key path and line.");
  m.def(
      "load_scene_text",
      [](const std::string& yaml, const std::string& label, const fs::path& base_dir, const py::object& overrides) {
        return make_scene(
            [yaml, label, base_dir](const std::vector<std::string>& o) {
              return io::load_scene_text(yaml, label, base_dir, o);
            },
            to_overrides(overrides));
      },
      py::arg("yaml"), py::arg("label") = "<text>", py::arg("base_dir") = fs::path("."),
      py::arg("overrides") = py::none(),
      "load_scene_text(yaml, label='<text>', base_dir='.', overrides=None)\n--\n\nLoads a scene from YAML text; "
      "`label` names it in errors.");
  m.def(
      "_load_scene_arrays",
      [](const std::string& yaml, const std::string& label, const py::dict& arrays, const py::object& overrides) {
        auto meshes = std::make_shared<std::map<std::string, io::MeshArrays>>();
        for (auto item : arrays) {
          const std::string key = py::str(item.first);
          py::tuple t = py::reinterpret_borrow<py::tuple>(item.second);
          io::MeshArrays a;
          // t[4] is the argument's name for the object, e.g. objects[0].
          const std::string name = py::str(t[4]);
          a.vertices = to_positions(t[0], (name + ".vertices").c_str());
          a.faces = to_rows<3>(t[1], (name + ".faces").c_str());
          a.edges = to_rows<2>(t[2], (name + ".edges").c_str());
          a.tets = to_rows<4>(t[3], (name + ".tets").c_str());
          (*meshes)[key] = std::move(a);
        }
        try {
          return make_scene(
              [yaml, label, meshes](const std::vector<std::string>& o) {
                return io::load_scene_arrays(yaml, label, *meshes, o);
              },
              to_overrides(overrides));
        } catch (const ConfigError& e) {
          // The document is generated from the arguments: its line numbers mean nothing to the
          // caller, the key path (objects[0].faces, time.fps) names the argument and entry.
          if (e.file() == label && e.line() != 0) throw ConfigError(label, e.key_path(), 0, e.detail());
          throw;
        }
      },
      py::arg("yaml"), py::arg("label"), py::arg("arrays"), py::arg("overrides") = py::none(),
      "_load_scene_arrays(yaml, label, arrays, overrides=None)\n--\n\nScene.from_arrays's loader: `arrays` maps "
      "each mesh path of `yaml` to (vertices, faces, edges, tets, argument name).");

  // ---- simulation
  py::class_<PySimulation>(m, "Simulation",
                           R"(Steps a scene frame by frame.

Simulation(scene, solver=None, threads=None): `solver` overrides contact.solver through the loader
(like `ccfr run --solver`); `threads` sets the process-wide worker count (None: all cores).

>>> sim = ccfr.Simulation(ccfr.load_scene("configs/drape.yaml"), threads=2)
>>> sim.step(2)["frame"], sim.frame, sim.positions.shape
(2, 2, (2323, 3))
>>> round(sim.time, 6)
0.033333
)")
      .def(py::init([](const PyScene& scene, const std::optional<std::string>& solver, std::optional<int> threads) {
             auto s = std::make_unique<PySimulation>();
             s->threads = threads.value_or(0);
             if (const std::string problem = thread_count_problem(s->threads); !problem.empty())
               throw py::value_error("threads " + problem + ", got " + std::to_string(s->threads));
             set_thread_count(s->threads);
             io::LoadedScene loaded;
             if (solver) {
               std::vector<std::string> o = scene.overrides;
               o.push_back("contact.solver=" + *solver);
               loaded = load_labelled(scene.load, o, o.back(), "Simulation(solver=" + *solver + ")");
             } else {
               loaded = scene.loaded;
             }
             s->resolved_json = loaded.resolved_json;
             s->memory = loaded.memory;
             const SimulationParams params = loaded.scene.params;
             try {
               s->sim = std::make_unique<Simulation>(std::move(loaded.scene));
             } catch (const Error& e) {
               // A component's own check names file, key path and line; an override's as load_labelled does.
               try {
                 io::rethrow_located(loaded, e);
               } catch (const ConfigError& c) {
                 const std::string head = "command line (--set ";
                 if (c.file().rfind(head, 0) == 0)
                   throw ConfigError("overrides (" + c.file().substr(head.size()), c.key_path(), 0, c.detail());
                 throw;
               }
             }
             if (params.debug.audit != AuditMode::off)
               s->sim->set_audit(io::make_audit_hook(s->sim->topology(), s->sim->positions(), params));
             return s;
           }),
           py::arg("scene"), py::arg("solver") = py::none(), py::arg("threads") = py::none(),
           "__init__(self, /, scene, solver=None, threads=None)\n--\n\nA simulation of `scene` (see the class).")
      .def(
          "step",
          [](PySimulation& s, int frames) {
            if (frames < 1) throw py::value_error("frames must be >= 1");
            for (int f = 0; f < frames; ++f) step_once(s);
            return frame_stats_dict(*s.last);
          },
          py::arg("frames") = 1,
          "step(self, /, frames=1)\n--\n\nAdvances `frames` frames (all substeps; the GIL is released meanwhile) and "
          "returns the last frame's "
          "stats row as a dict. Raises ccfr.GuaranteeError or ccfr.NumericalError like `ccfr run` stops.")
      .def_property_readonly(
          "positions", [](py::object self) { return view(self.cast<PySimulation&>().sim->positions(), self); },
          "Current positions: a read-only (n, 3) float64 view of the simulation's buffer (no copy; "
          "it follows every step). Use set_positions to change them.")
      .def_property_readonly(
          "velocities", [](py::object self) { return view(self.cast<PySimulation&>().sim->velocities(), self); },
          "Current velocities: a read-only (n, 3) float64 view, like positions.")
      .def(
          "set_positions",
          [](PySimulation& s, const py::object& x) { s.sim->set_positions(state_rows(s, x, "positions")); },
          py::arg("positions"),
          "set_positions(self, /, positions)\n--\n\nOverwrites every position ((n, 3), finite) between frames.")
      .def(
          "set_velocities",
          [](PySimulation& s, const py::object& v) { s.sim->set_velocities(state_rows(s, v, "velocities")); },
          py::arg("velocities"),
          "set_velocities(self, /, velocities)\n--\n\nOverwrites every velocity ((n, 3), finite) between frames.")
      .def(
          "set_kinematic_targets",
          [](PySimulation& s, const py::object& indices, const py::object& targets) {
            py::array raw = py::array::ensure(indices);
            if (!raw || raw.ndim() != 1 || (raw.size() > 0 && raw.dtype().kind() != 'i' && raw.dtype().kind() != 'u'))
              throw py::value_error("indices must be a 1-d integer array");
            IndexArray idx(raw);
            const Positions t = to_positions(targets, "targets");
            s.sim->set_kinematic_targets(std::span<const Index>(idx.data(), static_cast<size_t>(idx.size())), t);
          },
          py::arg("indices"), py::arg("targets"),
          "set_kinematic_targets(self, /, indices, targets)\n--\n\nDrives pinned or obstacle vertices (global "
          "indices): over the next frame each moves linearly to its target "
          "and then holds there.")
      .def_property_readonly(
          "stats",
          [](const PySimulation& s) -> py::object {
            return s.last ? py::object(frame_stats_dict(*s.last)) : py::object(py::none());
          },
          "The last frame's stats row (the columns of stats.csv) as a dict; None before a step.")
      .def_property_readonly(
          "frame", [](const PySimulation& s) { return s.sim->frames_done(); }, "Frames done.")
      .def_property_readonly(
          "time", [](const PySimulation& s) { return s.sim->scene().state.time; }, "Simulated time in seconds.")
      .def_property_readonly(
          "num_vertices", [](const PySimulation& s) { return s.sim->topology().num_vertices(); },
          "Vertices of all objects together.")
      .def_property_readonly(
          "solver", [](const PySimulation& s) { return s.sim->scene().params.contact.solver; },
          "The contact solver (contact.solver).")
      .def_property_readonly(
          "frames", [](const PySimulation& s) { return s.sim->scene().params.time.frames; },
          "time.frames of the scene.")
      .def_property_readonly(
          "kinematic_vertices",
          [](const PySimulation& s) {
            const auto& st = s.sim->scene().state;
            std::vector<Index> k;
            for (Index v = 0; v < st.size(); ++v)
              if (st.inv_mass[v] == 0.0) k.push_back(v);
            return py::array_t<Index>(static_cast<py::ssize_t>(k.size()), k.data());
          },
          "Global indices of the pinned and obstacle vertices (those set_kinematic_targets accepts).");

  // ---- run directories
  py::class_<PyRun>(m, "Run",
                    R"(Writes the run directory of `ccfr run` (run.json, frames/, stats.csv) while stepping.

Run(sim, dir, force=False, last_frame=None, argv=None). Frame 0 is written on entry, frame f when f
is a multiple of output.every or equals `last_frame` (default time.frames), and run.json's status
on exit ('completed', or 'failed: ...'). `force` replaces an earlier run in `dir`; `argv` is the
command line run.json records (default sys.argv).

>>> sim = ccfr.Simulation(ccfr.load_scene("configs/drape.yaml", overrides={"time.frames": 2}), threads=2)
>>> with ccfr.Run(sim, "out/drape_doc", force=True) as run:
...     for _ in range(sim.frames):
...         stats = run.step()
>>> run.frames_written, stats["frame"], ccfr.audit("out/drape_doc").verdict
(3, 2, 'pass')
)")
      .def(py::init([](py::object sim, const fs::path& dir, bool force, std::optional<int> last_frame,
                       std::optional<std::vector<std::string>> argv) {
             auto r = std::make_unique<PyRun>();
             r->sim_owner = sim;
             r->sim = &sim.cast<PySimulation&>();
             std::vector<std::string> args =
                 argv ? *argv : py::module_::import("sys").attr("argv").cast<std::vector<std::string>>();
             std::string cmd = "python3";
             for (const auto& a : args) cmd += " " + a;
             const int last = last_frame.value_or(r->sim->sim->scene().params.time.frames);
             io::RunMeta meta = io::make_run_meta(*r->sim->sim, cmd, {});
             meta.memory_estimate = r->sim->memory.total_bytes;
             meta.memory_limit = r->sim->memory.limit_bytes;
             r->recorder = std::make_unique<io::RunRecorder>(dir, *r->sim->sim, r->sim->resolved_json, std::move(meta),
                                                             last, force);
             return r;
           }),
           py::arg("sim"), py::arg("dir"), py::arg("force") = false, py::arg("last_frame") = py::none(),
           py::arg("argv") = py::none(),
           "__init__(self, /, sim, dir, force=False, last_frame=None, argv=None)\n--\n\nA run of `sim` into "
           "`dir` (see the class).")
      .def(
          "__enter__",
          [](py::object self) {
            auto& r = self.cast<PyRun&>();
            if (r.started) throw py::value_error("a Run is entered once");
            r.started = true;
            r.recorder->start();
            return self;
          },
          "__enter__(self, /)\n--\n\nWrites run.json (status running) and frame 0.")
      .def(
          "step",
          [](PyRun& r, int frames) {
            if (!r.started || r.finished) throw py::value_error("Run.step() works inside `with ccfr.Run(...)`");
            if (frames < 1) throw py::value_error("frames must be >= 1");
            for (int f = 0; f < frames; ++f) r.recorder->record(step_once(*r.sim));
            return frame_stats_dict(*r.sim->last);
          },
          py::arg("frames") = 1,
          "step(self, /, frames=1)\n--\n\nSteps the simulation and writes what belongs to each frame; returns the last "
          "stats.")
      .def(
          "__exit__",
          [](PyRun& r, const py::object& type, const py::object& value, const py::object&) {
            if (r.finished) return false;
            r.finished = true;
            r.recorder->finish(value.is_none() ? std::string("completed")
                                               : "failed: " + py::str(value).cast<std::string>());
            return false;
          },
          "__exit__(self, type, value, traceback, /)\n--\n\nRecords run.json's status: 'completed', or 'failed: "
          "<exception>' when the block raised (which propagates).")
      .def_property_readonly(
          "dir", [](const PyRun& r) { return r.recorder->writer().dir(); },
          "Where the run is written (DIR, or DIR.ccfr-new while it replaces an earlier run).")
      .def_property_readonly(
          "frames_written", [](const PyRun& r) { return r.recorder->writer().frames_written(); },
          "Frame files written so far (frame 0 included).");

  // ---- audit
  py::class_<io::FrameAuditRow>(m, "FrameAudit", "One audited frame.")
      .def_readonly("frame", &io::FrameAuditRow::frame, "The frame number.")
      .def_readonly("file", &io::FrameAuditRow::file, "The frame file audited.")
      .def_readonly("triangle_intersections", &io::FrameAuditRow::triangle_intersections,
                    "Pairs of triangles that intersect.")
      .def_readonly("segment_crossings", &io::FrameAuditRow::segment_crossings,
                    "Strand segments crossing each other or a triangle.")
      .def_readonly("close_pairs", &io::FrameAuditRow::close_pairs, "Pairs closer than the offset minus the tolerance.")
      .def_readonly("min_distance", &io::FrameAuditRow::min_distance,
                    "The smallest distance between non-adjacent pairs.")
      .def_readonly("examples", &io::FrameAuditRow::examples, "A few offending pairs, described.")
      .def_property_readonly("clean", &io::FrameAuditRow::clean, "No intersection, crossing or close pair.")
      .def("__repr__", [](const io::FrameAuditRow& r) {
        return "<FrameAudit " + std::to_string(r.frame) + ": " + (r.clean() ? "clean" : "violations") + ">";
      });
  struct PyAudit {
    io::RunAuditResult r;
    std::string verdict;
  };
  py::class_<PyAudit>(m, "AuditResult", "The exact penetration audit of a run directory (`ccfr audit`).")
      .def_readonly("verdict", &PyAudit::verdict, "'pass', 'fail' or 'incomplete' (docs/audit.md).")
      .def_property_readonly(
          "clean", [](const PyAudit& a) { return a.r.clean(); }, "Every audited frame is clean.")
      .def_property_readonly(
          "offset", [](const PyAudit& a) { return a.r.offset; }, "The offset ξ audited against.")
      .def_property_readonly(
          "offset_source", [](const PyAudit& a) { return a.r.offset_source; },
          "Where ξ came from: 'run.json', or '--offset' (the offset argument).")
      .def_property_readonly(
          "status", [](const PyAudit& a) { return a.r.status; }, "run.json's status.")
      .def_property_readonly(
          "frames_checked", [](const PyAudit& a) { return a.r.frames_checked; }, "Frames audited.")
      .def_property_readonly(
          "frames_total", [](const PyAudit& a) { return a.r.frames_total; }, "Frame files in the run.")
      .def_property_readonly(
          "bad_frames", [](const PyAudit& a) { return a.r.bad_frames; }, "Frames with a violation.")
      .def_property_readonly(
          "violations", [](const PyAudit& a) { return a.r.violations; }, "Violations over all frames.")
      .def_property_readonly(
          "first_bad_frame", [](const PyAudit& a) { return a.r.first_bad_frame; }, "The first bad frame (-1: none).")
      .def_property_readonly(
          "first_example", [](const PyAudit& a) { return a.r.first_example; }, "The first violation, described.")
      .def_property_readonly(
          "min_distance", [](const PyAudit& a) { return a.r.min_distance; }, "The smallest distance of the run.")
      .def_property_readonly(
          "rows", [](const PyAudit& a) { return a.r.rows; }, "One FrameAudit per audited frame.")
      .def("__bool__", [](const PyAudit& a) { return a.verdict == "pass"; })
      .def("__repr__", [](const PyAudit& a) {
        return "<AuditResult " + a.verdict + ": " + std::to_string(a.r.frames_checked) + " frames, " +
               std::to_string(a.r.violations) + " violations>";
      });
  m.def(
      "audit",
      [](const fs::path& dir, std::optional<double> offset, double tolerance, int stride, bool partial,
         bool write_report) {
        io::RunAuditOptions o;
        o.offset = offset;
        o.tolerance = tolerance;
        o.stride = stride;
        if (const std::string problem = io::audit_options_problem(o); !problem.empty()) throw py::value_error(problem);
        PyAudit a;
        a.r = require_existing(dir, [&] {
          py::gil_scoped_release release;
          return io::audit_run(dir, o);
        });
        a.verdict = io::audit_verdict(a.r, partial);
        if (write_report) {
          const int code = io::audit_exit_code(a.r, a.verdict);
          io::write_file_atomic(
              dir / "audit.json",
              io::audit_report_json(a.r, a.verdict, code, partial && a.r.has_run_json && !a.r.completed()));
        }
        return a;
      },
      py::arg("run_dir"), py::arg("offset") = py::none(), py::arg("tolerance") = 1e-6, py::arg("stride") = 1,
      py::arg("partial") = false, py::arg("write_report") = false,
      "audit(run_dir, offset=None, tolerance=1e-06, stride=1, partial=False, write_report=False)\n--\n\n"
      "Audits a run directory frame by frame with the exact predicates (`ccfr audit`). offset: ξ (default: "
      "run.json's). write_report: also write DIR/audit.json as `ccfr audit` does.");

  // ---- projectors and closest points
  py::class_<ProjectResult>(m, "Projection", "The result of ccfr.project.")
      .def_property_readonly(
          "x", [](const ProjectResult& r) { return py::array_t<double>(3, r.x.data()); }, "The projected point.")
      .def_property_readonly(
          "status", [](const ProjectResult& r) { return std::string(to_string(r.status)); },
          "'feasible', 'projected', 'halted' or 'infeasible'.")
      .def_readonly("iterations", &ProjectResult::iterations, "Iterations the method took.")
      .def_readonly("active", &ProjectResult::active, "Half-spaces violated by the candidate.")
      .def_readonly(
          "fell_back", &ProjectResult::fell_back,
          "Plesník only: its point was farther from the candidate than the anchor, so x is the exact projection.");
  m.def("projector_names", &projector_names,
        "projector_names()\n--\n\nThe projector methods: plesnik, successive_projection, exact.");
  m.def(
      "project",
      [](const py::object& anchor, const py::object& candidate, const py::object& planes, const std::string& method,
         double epsilon, int max_iterations, int sweeps) {
        const Positions a = to_positions(real_array(anchor, "anchor").reshape({1, 3}), "anchor");
        const Positions c = to_positions(real_array(candidate, "candidate").reshape({1, 3}), "candidate");
        RowArray p = real_array(planes, "planes");
        if (!p || (p.size() > 0 && (p.ndim() != 2 || p.shape(1) != 4)) || (p.size() == 0 && p.ndim() > 2))
          throw py::value_error("planes must be a (k, 4) array of rows (nx, ny, nz, d)");
        std::vector<HalfSpace> hs(static_cast<size_t>(p.size() / 4));
        const double* d = p.data();
        for (size_t k = 0; k < hs.size(); ++k)
          hs[k].n = Vec3(d[4 * k], d[4 * k + 1], d[4 * k + 2]), hs[k].d = d[4 * k + 3];
        // Bounded as scene coordinates are (kMaxCoordinate), normals unit within 1e-6.
        const auto bounded = [](const Vec3& x, const char* name) {
          if (!x.allFinite() || x.cwiseAbs().maxCoeff() > kMaxCoordinate)
            throw py::value_error(std::string(name) + " must be finite, within +-1e6 (ccfr's bound on coordinates)");
        };
        bounded(a[0], "anchor"), bounded(c[0], "candidate");
        for (size_t k = 0; k < hs.size(); ++k) {
          if (!hs[k].n.allFinite() || !std::isfinite(hs[k].d) || std::abs(hs[k].d) > kMaxCoordinate ||
              std::abs(hs[k].n.norm() - 1) > 1e-6)
            throw py::value_error("planes row " + std::to_string(k) +
                                  " must hold a unit normal and a finite d within +-1e6");
        }
        ProjectorParams pp;
        pp.epsilon = epsilon;
        pp.max_iterations = max_iterations;
        pp.sweeps = sweeps;
        try {
          validate(pp);  // the bounds of the scene's projector keys
        } catch (const Error& e) {
          throw py::value_error(e.what());
        }
        return make_projector(method, pp)->project(a[0], c[0], hs);
      },
      py::arg("anchor"), py::arg("candidate"), py::arg("planes"), py::arg("method") = "plesnik",
      py::arg("epsilon") = 1e-6, py::arg("max_iterations") = 4, py::arg("sweeps") = 10,
      "project(anchor, candidate, planes, method='plesnik', epsilon=1e-06, max_iterations=4, sweeps=10)\n--\n\n"
      "Projects `candidate` into the region {x : (x - anchor).n_k + d_k >= 0} of the half-spaces `planes` (rows "
      "nx, ny, nz, d; unit normals), by `method` (ccfr.projector_names()).");
  auto vec = [](const py::object& o, const char* what) {
    return to_positions(real_array(o, what).reshape({1, 3}), what)[0];
  };
  auto arr = [](const Vec3& v) { return py::array_t<double>(3, v.data()); };
  m.def(
      "point_edge",
      [vec, arr](const py::object& p, const py::object& a, const py::object& b) {
        const auto r = point_edge(vec(p, "p"), vec(a, "a"), vec(b, "b"));
        py::dict d;
        d["closest"] = arr(r.closest), d["t"] = r.t, d["distance"] = std::sqrt(r.distance_sq);
        d["feature"] = r.feature == EdgeFeature::v0 ? "v0" : r.feature == EdgeFeature::v1 ? "v1" : "interior";
        return d;
      },
      py::arg("p"), py::arg("a"), py::arg("b"),
      "point_edge(p, a, b)\n--\n\nClosest point of segment ab to p: dict closest, t (closest = a + t (b - a)), "
      "distance, feature.");
  m.def(
      "point_triangle",
      [vec, arr](const py::object& p, const py::object& a, const py::object& b, const py::object& c) {
        const auto r = point_triangle(vec(p, "p"), vec(a, "a"), vec(b, "b"), vec(c, "c"));
        static const char* names[] = {"v0", "v1", "v2", "e01", "e12", "e20", "interior"};
        py::dict d;
        d["closest"] = arr(r.closest), d["bary"] = arr(r.bary), d["distance"] = std::sqrt(r.distance_sq);
        d["feature"] = names[static_cast<int>(r.feature)];
        return d;
      },
      py::arg("p"), py::arg("a"), py::arg("b"), py::arg("c"),
      "point_triangle(p, a, b, c)\n--\n\nClosest point of triangle abc to p: dict closest, bary (barycentrics), "
      "distance, feature.");
  m.def(
      "edge_edge",
      [vec, arr](const py::object& a0, const py::object& a1, const py::object& b0, const py::object& b1) {
        const auto r = edge_edge(vec(a0, "a0"), vec(a1, "a1"), vec(b0, "b0"), vec(b1, "b1"));
        py::dict d;
        d["pa"] = arr(r.pa), d["pb"] = arr(r.pb), d["s"] = r.s, d["t"] = r.t;
        d["distance"] = std::sqrt(r.distance_sq), d["parallel"] = r.parallel;
        return d;
      },
      py::arg("a0"), py::arg("a1"), py::arg("b0"), py::arg("b1"),
      "edge_edge(a0, a1, b0, b1)\n--\n\nClosest points of segments a0a1 and b0b1: dict pa, pb, s, t, distance, "
      "parallel.");
}
