#pragma once
// The line csv_writer.cpp writes for one vertex, for main.cpp to check its files against.
#include <ccfr/core/types.hpp>

#include <string>

std::string csv_line(const ccfr::Vec3& p, int digits);
