// The `solver:` section of a scene, parsed (src/scene/scene.cpp reads the rest).
#pragma once

#include "scene/scene.hpp"
#include "scene/yaml_schema.hpp"

namespace peristat {

/// Default solver.newton.atol per E t dx of the stiffest material: 7e-10 N for the aluminium
/// cases at dx = 1 mm, far below their rtol 1e-10 x force scale (about 1e-6 N).
inline constexpr double kAtolPerForceUnit = 1e-14;

SolverOptions read_solver(const schema::Field& field);

}  // namespace peristat
