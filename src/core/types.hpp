// Basic numeric types shared by every target.
#pragma once

#include <cstdint>

#include <Eigen/Core>
#include <Eigen/SparseCore>

namespace peristat {

using Index = std::int32_t;  // particle, bond and dof indices (fits 2^31 unknowns)
using Vec2 = Eigen::Vector2d;
using Mat2 = Eigen::Matrix2d;
using VectorXd = Eigen::VectorXd;
using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, Index>;

}  // namespace peristat
