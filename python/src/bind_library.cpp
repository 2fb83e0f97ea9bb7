// The library-wide functions of ccfr._core: set_log_level and version.
#include <string>

#include "bindings.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/io/output.hpp"

namespace ccfr::python {

void define_library(py::module_& m) {
  m.def(
      "set_log_level", [](const std::string& level) { init_logging(level); }, py::arg("level"),
      "set_log_level(level)\n--\n\nSets the level of ccfr's log on stderr: trace, debug, info, warn (the default in "
      "Python), error or off.");
  m.def("version", &io::version, "version()\n--\n\nThe library version (the CMake project version).");
}

}  // namespace ccfr::python
