#pragma once
// A scene as ccfr.Scene holds it, and loading one from Python arguments: overrides from a dict or
// a list, and the loader's errors relabelled as the arguments that caused them.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "ccfr/io/scene_loader.hpp"

namespace ccfr::python {

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
std::vector<std::string> to_overrides(const py::object& o);

using Loader = std::function<io::LoadedScene(const std::vector<std::string>&)>;

/// Runs `load`, relabelling what the loader blames on `--set` (it serves the command line) as the
/// Python argument that carried it: "overrides (key=value)", or `solver_label` for `solver_item`.
/// A mesh file that does not exist becomes MissingMesh.
io::LoadedScene load_labelled(const Loader& load, const std::vector<std::string>& overrides,
                              const std::string& solver_item = "", const std::string& solver_label = "");

/// A scene loaded by `load` with `overrides` (errors as load_labelled gives them), kept with both so
/// that it can be loaded again with more.
std::shared_ptr<PyScene> make_scene(Loader load, std::vector<std::string> overrides);

}  // namespace ccfr::python
