// ccfr.Scene and its loaders (load_scene, load_scene_text, _load_scene_arrays), and the overrides
// and error relabelling of bind_scene.hpp that they and ccfr.Simulation share.
#include "bind_scene.hpp"

#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "arrays.hpp"
#include "bind_errors.hpp"
#include "bindings.hpp"
#include "ccfr/core/error.hpp"

namespace ccfr::python {

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

io::LoadedScene load_labelled(const Loader& load, const std::vector<std::string>& overrides,
                              const std::string& solver_item, const std::string& solver_label) {
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

namespace {

// ccfr.Scene: its properties, with_overrides and repr.
void define_scene_class(py::module_& m) {
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
}

// The loaders of a scene from a file, from YAML text, and from arrays (Scene.from_arrays).
void define_scene_loaders(py::module_& m) {
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
}

}  // namespace

void define_scene(py::module_& m) {
  define_scene_class(m);
  define_scene_loaders(m);
}

}  // namespace ccfr::python
