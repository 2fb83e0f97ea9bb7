#pragma once
/// @file types.hpp
/// Scalar, index and small fixed-size vector types shared by every ccfr module.
#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products are used everywhere

#include <cstdint>
#include <vector>

namespace ccfr {

using Index = std::int32_t;  ///< vertex, edge, face and tet indices (scenes stay far below 2^31)
using Vec3 = Eigen::Vector3d;
using Vec2i = Eigen::Matrix<Index, 2, 1>;
using Vec3i = Eigen::Matrix<Index, 3, 1>;
using Vec4i = Eigen::Matrix<Index, 4, 1>;
using Positions = std::vector<Vec3>;  ///< #V positions, one flat array for the whole scene

}  // namespace ccfr
