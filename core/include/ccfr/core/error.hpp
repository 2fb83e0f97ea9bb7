#pragma once
/// @file error.hpp
/// Errors that are the user's to fix (bad configuration, missing files, NaN in the input) are
/// `ccfr::Error`; the CLI prints them as one line and exits non-zero. Programming errors stay
/// assertions or std::logic_error.
#include <stdexcept>
#include <string>

#include "ccfr/core/types.hpp"

namespace ccfr {

/// A user-facing error. `what()` is the full message, ready to print.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

/// A configuration error located in a file: "file:line: key.path: message".
class ConfigError : public Error {
 public:
  ConfigError(std::string file, std::string key_path, int line, std::string message);
  const std::string& file() const { return file_; }
  const std::string& key_path() const { return key_path_; }
  int line() const { return line_; }  ///< 1-based; 0 when unknown (e.g. a --set override)
  const std::string& detail() const { return detail_; }

 private:
  std::string file_, key_path_, detail_;
  int line_;
};

/// The simulation produced a non-finite value; names where it was first seen: frame, stage,
/// vertex (global index) and, when known, its object and index within that object.
class NumericalError : public Error {
 public:
  NumericalError(int frame, Index vertex, std::string stage);
  NumericalError(int frame, Index vertex, std::string stage, std::string object, Index object_vertex);
  int frame() const { return frame_; }
  Index vertex() const { return vertex_; }
  const std::string& stage() const { return stage_; }
  const std::string& object() const { return object_; }   ///< empty when not known
  Index object_vertex() const { return object_vertex_; }  ///< -1 when not known

 private:
  int frame_;
  Index vertex_;
  std::string stage_;
  std::string object_;
  Index object_vertex_ = -1;
};

/// The run cannot keep its promise: a substep ended with pairs closer than their offset under a
/// solver that guarantees separation, or scripted motion outruns what the regions can absorb.
/// Thrown before the frame is written, so every frame on disk stays clean.
class GuaranteeError : public Error {
 public:
  GuaranteeError(int frame, std::string message);
  int frame() const { return frame_; }

 private:
  int frame_;
};

}  // namespace ccfr
