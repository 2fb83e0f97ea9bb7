#include "ccfr/core/log.hpp"

#include <string>

namespace ccfr {

void init_logging(std::string_view level) {
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
  spdlog::set_level(spdlog::level::from_str(std::string(level)));
}

}  // namespace ccfr
