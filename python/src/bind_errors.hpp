#pragma once
// The C++ exceptions of the bindings for missing files (ccfr.MissingFileError and
// ccfr.MissingMeshError, raised by the translator of bind_errors.cpp), and require_existing.
#include <filesystem>
#include <string>
#include <system_error>
#include <utility>

#include "ccfr/core/error.hpp"

namespace ccfr::python {

/// A scene file or run directory that does not exist (raised as ccfr.MissingFileError).
struct MissingFile : Error {
  MissingFile(const std::string& message, std::filesystem::path p) : Error(message), path(std::move(p)) {}
  std::filesystem::path path;
};

/// A mesh file named by a scene that does not exist (ccfr.MissingMeshError, a ConfigError too).
struct MissingMesh : ConfigError {
  MissingMesh(const ConfigError& e, std::filesystem::path p)
      : ConfigError(e.file(), e.key_path(), e.line(), e.detail()), path(std::move(p)) {}
  std::filesystem::path path;
};

/// Runs `f`; a ccfr::Error while `path` does not exist becomes MissingFile with the same message.
template <class F>
auto require_existing(const std::filesystem::path& path, F&& f) {
  try {
    return f();
  } catch (const ConfigError&) {
    throw;
  } catch (const Error& e) {
    std::error_code ec;
    if (!path.empty() && std::filesystem::status(path, ec).type() == std::filesystem::file_type::not_found)
      throw MissingFile(e.what(), path);
    throw;
  }
}

}  // namespace ccfr::python
