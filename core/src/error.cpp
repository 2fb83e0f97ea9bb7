#include "ccfr/core/error.hpp"

#include <string_view>

namespace ccfr {

namespace {
std::string format_config_error(const std::string& file, const std::string& key_path, int line,
                                const std::string& message) {
  std::string out;
  out.append(file.empty() ? std::string_view("<config>") : std::string_view(file));
  if (line > 0) out.append(":").append(std::to_string(line));
  out.append(": ");
  if (!key_path.empty()) out.append("'").append(key_path).append("': ");
  out.append(message);
  return out;
}
}  // namespace

ConfigError::ConfigError(std::string file, std::string key_path, int line, std::string message)
    : Error(format_config_error(file, key_path, line, message)),
      file_(std::move(file)),
      key_path_(std::move(key_path)),
      detail_(std::move(message)),
      line_(line) {}

NumericalError::NumericalError(int frame, Index vertex, std::string stage)
    : Error("non-finite position at frame " + std::to_string(frame) + ", vertex " + std::to_string(vertex) +
            ", after stage '" + stage + "'"),
      frame_(frame),
      vertex_(vertex),
      stage_(std::move(stage)) {}

NumericalError::NumericalError(int frame, Index vertex, std::string stage, std::string object, Index object_vertex)
    : Error("non-finite position at frame " + std::to_string(frame) + ", vertex " + std::to_string(vertex) +
            " (object '" + object + "', vertex " + std::to_string(object_vertex) + " of the object), after stage '" +
            stage + "'"),
      frame_(frame),
      vertex_(vertex),
      stage_(std::move(stage)),
      object_(std::move(object)),
      object_vertex_(object_vertex) {}

GuaranteeError::GuaranteeError(int frame, std::string message)
    : Error("frame " + std::to_string(frame) + ": " + message), frame_(frame) {}

}  // namespace ccfr
